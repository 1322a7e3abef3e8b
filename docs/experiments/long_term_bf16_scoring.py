"""bfloat16 trajectory decoding for the long-term Y-net: what it changes and what it saves, on validation.

Not a test: prints numbers. The evidence behind `eval.cpu.bf16`: the trained `cpu` model
(`data/ynet/model.pt`, stage train_ynet) scores the release's *validation* windows (never the test
set) at the main setting (TTST + CWS, K_e x K_a from `eval.cpu`, `ttst` / `cws` from params.yaml)
three times, same model and same input order:

- float32, seed s (the reference);
- bfloat16 trajectory decoder, seed s (same goals and waypoints: only the decoder's precision moves);
- float32, seed s + 1 (another evaluation round: the spread a reader already sees as "±").

bf16 is acceptable when its change of ADE is small beside the round-to-round change.
Written up in docs/profiles.md (row "Y-net long-term scoring"). FDE comes from
the goals, which bf16 never touches, so it must be identical.

    python -m docs.experiments.long_term_bf16_scoring [--threads 2] \
        [--windows data/windows/release_tf30.parquet]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
import torch

from bench.bench_ynet import keep_freed_memory
from docs.experiments import long_term_validation
from pipeline.device import cpu_has_bf16
from pipeline.harness.metrics import window_errors
from pipeline.runners.ynet_scoring import predict_scenes, sampling_options


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    long_term_validation.add_arguments(parser)
    args = parser.parse_args()
    keep_freed_memory()

    trained = long_term_validation.load(args)
    model, settings, scenes, val = trained.model, trained.settings, trained.scenes, trained.val
    eval_params = trained.eval_params
    options = sampling_options(eval_params.k_e, eval_params.k_a, trained.ttst, trained.cws, True, True)
    print(f"torch {torch.__version__}, {args.threads} threads; {len(val)} validation windows, "
          f"K_e {options.K_e} x K_a {options.K_a}, model {args.model}")

    def score(bf16: bool, seed: int) -> tuple[np.ndarray, np.ndarray, float]:
        run_params = dataclasses.replace(eval_params, bf16=bf16)
        start = time.perf_counter()
        paths, goals = predict_scenes(model, scenes, settings, options, seed, run_params, len(val),
                                      f"bf16={bf16} seed={seed}")
        return paths, goals, time.perf_counter() - start

    runs = {"float32, seed s": score(False, eval_params.seed),
            "bfloat16, seed s": score(True, eval_params.seed),
            "float32, seed s+1": score(False, eval_params.seed + 1)}
    print("CPU bf16 hardware (AVX-512 BF16 or AMX): "
          f"{'yes' if cpu_has_bf16() else 'no, so the bf16 cases run float32 (pipeline.device.use_bf16)'}")
    print(f"\n{'run':<20}{'ADE px':>10}{'FDE px':>10}{'s/window':>10}")
    errors = {}
    for name, (paths, goals, seconds) in runs.items():
        errors[name] = window_errors(paths, val.future, goals)
        print(f"{name:<20}{errors[name].ade.mean():>10.3f}{errors[name].fde.mean():>10.3f}"
              f"{seconds / len(val):>10.3f}")
    reference, bf16 = runs["float32, seed s"][0], runs["bfloat16, seed s"][0]
    moved = np.linalg.norm(bf16 - reference, axis=-1)  # (N, K, n_f) px
    ade_bf16 = errors["bfloat16, seed s"].ade.mean() - errors["float32, seed s"].ade.mean()
    ade_round = errors["float32, seed s+1"].ade.mean() - errors["float32, seed s"].ade.mean()
    same_goals = np.array_equal(runs["bfloat16, seed s"][1], runs["float32, seed s"][1])
    print(f"\nbf16 - float32, same seed: ADE {ade_bf16:+.3f} px, FDE "
          f"{'identical' if same_goals else 'DIFFERENT'}; trajectory points moved "
          f"{moved.mean():.3f} px mean, {moved.max():.2f} px max")
    print(f"another round (seed s+1) - seed s, float32: ADE {ade_round:+.3f} px")
    print(f"speed: bf16 {runs['float32, seed s'][2] / runs['bfloat16, seed s'][2]:.2f}x float32")


if __name__ == "__main__":
    main()
