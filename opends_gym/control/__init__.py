"""Low-level controllers (lane keeping, speed holding) used by the envs' meta-actions and the
drivers alike: a layer below both, above the simulation core."""
