"""Helpers shared by the tests and the benchmarks (never a test module itself): an
independent MCAP writer (:mod:`.recordings`), scenario snippets (:mod:`.scenarios`),
random rigs and visit tables (:mod:`.coverage`), the SPEC §6 effect cases
(:mod:`.effects`), recordings of other writers for campaigns (:mod:`.foreign`), the rig-TOML
template of the random rigs and the UR5 fixture (:mod:`.rigs`), the paper rig's mutations for
the rig tests (:mod:`.rig_mutations`), the command line run as a user does (:mod:`.cli`)."""
