"""The report's sections, one module each, in the order :func:`thermrs.report.document.compose`
puts them (:data:`thermrs.report.blocks.SECTION_IDS`): ``summary``, ``rig``, ``runs``,
``heating``, ``tables`` (Tables 4, 6, 7), ``prediction``, ``iso`` (ISO 9283), ``diagnosis``
(with ``design``, the experiment that settles an ambiguous one) and ``extraction``. Each builds
a :class:`~thermrs.report.blocks.Section` from :class:`~thermrs.report.data.ReportData`;
``common`` holds the prose helpers they share.
"""
