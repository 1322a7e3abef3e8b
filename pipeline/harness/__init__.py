"""Harness: the one metric every model is scored with, the baselines (constant velocity, S-GAN,
PECNet, R-PECNet) behind one interface, training and scoring one baseline at one horizon, the
chain-bias measurement, the stored-predictions format (`predictions`) and every metric computed
from stored predictions (`scoring`)."""
