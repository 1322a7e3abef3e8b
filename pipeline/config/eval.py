"""Section `eval.<profile>` of params.yaml: how the long-term Y-net is scored (K_e, K_a, rounds,
the ablation and the K_a grid, batches)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class EvalParams:
    k_e: int = 20
    """Goals per window for the main result."""
    k_a: int = 1
    """Paths per goal for the main result."""
    rounds: int = 3
    """Seeded evaluation rounds of the main result; mean and spread are reported."""
    ablation_rounds: int = 1
    """Rounds of each Table 3 ablation row (0 = skip the ablation)."""
    ka_grid_k_e: list[int] = field(default_factory=lambda: [20])
    """K_e values of the K_a figure's grid (empty = skip the grid)."""
    ka_grid_k_a: list[int] = field(default_factory=lambda: [1, 2, 5])
    """K_a values of the K_a figure's grid."""
    seed: int = 0
    """Round r uses seed + r."""
    batch_size: int = 4
    """Windows per forward pass (one scene per batch)."""
    chunk_size: int = 4
    """Samples per window decoded together by the trajectory decoder."""
    bf16: bool = False
    """bfloat16 autocast for the convolutions (faster on CPUs with AMX; positions change slightly)."""
    threads: int = 2
    """torch CPU threads for scoring (training's are `ynet.<profile>.threads`: a model trained on
    one thread, beside another training, is scored alone on every core)."""
    qualitative_scenes: list[str] = field(default_factory=lambda: ["hyang_0", "little_2", "nexus_6"])
    """Test scenes whose longest-moving window is drawn in the qualitative figure."""

    def __post_init__(self):
        if min(self.k_e, self.k_a, self.rounds, self.batch_size, self.chunk_size, self.threads) < 1:
            raise ValueError("k_e, k_a, rounds, batch_size, chunk_size and threads must be positive")
