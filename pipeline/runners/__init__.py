"""Runners: the training loops and scoring of the learned models: the paper's baselines with their
epoch loop (`baselines`) and their runs at one horizon (`baseline_runs`), Y-net training and
scoring (the main / ablation / K_a evaluation sequence written once), the scene U-Net's training,
and the short-term and inD benchmarks built from them."""
