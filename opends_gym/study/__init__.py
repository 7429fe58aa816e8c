"""Studies: participants x conditions x tasks x repetitions, run on virtual participants (a
process pool or Ray) or driven by a person block by block, into one long-format table with a
mixed-effects summary, effect sizes, a simulated power analysis and an HTML report.

Why a layer of its own: a study composes envs, drivers, recording and human sessions; nothing
below it needs to know that studies exist.
"""
