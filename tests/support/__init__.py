"""Helpers shared by the tests and the benchmarks (never a test module itself): an
independent MCAP writer (:mod:`.recordings`), scenario snippets (:mod:`.scenarios`),
random rigs and visit tables (:mod:`.coverage`), the SPEC §6 effect cases
(:mod:`.effects`), recordings of other writers for campaigns (:mod:`.foreign`)."""
