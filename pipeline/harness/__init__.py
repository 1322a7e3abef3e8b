"""Harness: the one metric every model is scored with, fitting and scoring a registered model with
the one scoring loop, the epoch selection rules, the stored-predictions format (`predictions`) and
every metric computed from stored predictions (`scoring`, `stored_scores`)."""
