"""Offline data: drives (recordings, OpenDS logs) as episodes of an env, Minari datasets, behaviour cloning,
and a drive placed within a population.

Why a layer of its own: it stands on the envs, the drivers, the recordings and the study table at once,
and nothing below it needs datasets.
"""
