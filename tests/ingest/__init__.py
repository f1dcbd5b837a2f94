"""Reading MCAP files of every layout: the mcap project's conformance files, and layouts no
conforming writer produces."""
