"""Harness: the one metric every model is scored with, the baselines (S-GAN, PECNet, R-PECNet)
behind one interface, training and scoring one baseline at one horizon, fitting and scoring a
registered model, the epoch selection rules, the stored-predictions format (`predictions`) and
every metric computed from stored predictions (`scoring`, `stored_scores`)."""
