"""Studies: the one-off analyses, each the library of one stage (the horizon analysis, the chain
bias, the spread over training seeds, R-PECNet's roll-outs, PECNet's test-selection diagnostics,
the split-half study of the epoch selection rules). They sit above harness and runners, whose
models, metrics and scoring they use; nothing but stages imports them."""
