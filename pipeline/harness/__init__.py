"""Harness: the one metric every model is scored with, the baselines (constant velocity, S-GAN,
PECNet, R-PECNet) behind one interface, training and scoring one baseline at one horizon, and the
chain-bias measurement."""
