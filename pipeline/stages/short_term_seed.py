"""Stage `short_term_seed@<dataset>-<model>-<seed>` (studies/dvc.yaml, frozen): one short-term
model of the paper's Tables 1-2 (S-GAN, PECNet or Y-net) trained again with another training seed
and scored exactly as the headline run, for the tables' training-seed spread.

The model's training stage with its training seed replaced by `--seed` (`train_baseline.seed`
for the baselines, `ynet.<profile>.seed` for Y-net: initial weights, batch order, training noise
and latents or augmentations), then its scoring stage with the headline's own scoring seed, so
that two seeds differ in training alone. Both stages run as they are, as commands in the scratch
folder beside a copy of params.yaml that differs in that one key (`pipeline.runners.studies`):
their code, fingerprints and lock entries stay the main pipeline's. Writes one JSON, `--result`:
the run record the scoring stage writes, plus the training seed and the machine it ran on (a CPU
kind moves the last bits of a training: docs/experiments/2026-11-28-other-cpu.md). Checkpoints and
predictions stay in `--scratch`, which is no output: a stopped run resumes there, and only the
record is committed. Params: those of the two stages.

    python -m pipeline.stages.short_term_seed --dataset sdd --model pecnet --seed 1 \
        --windows data/short_term --scratch checkpoints/studies/short_term_seeds/sdd_pecnet_seed1 \
        --result studies/short_term_seeds/sdd_pecnet_seed1.json
    python -m pipeline.stages.short_term_seed --dataset eth --model ynet --seed 1 \
        --windows data/short_term --maps data/short_term/ethucy_semantic --sdd data/raw/sdd \
        --ethucy-scenes data/raw/ethucy-scenes --scratch ... --result ...
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from pipeline.config.loading import active_profile, read_params
from pipeline.dataset_list import SHORT_TERM_DATASETS
from pipeline.io import write_json
from pipeline.model_list import SHORT_TERM_MODELS, YNET
from pipeline.report.run_provenance import machine
from pipeline.runners.studies import run_stage, scratch_params, short_term_commands


def seed_key(model: str, profile: str) -> str:
    return f"ynet.{profile}.seed" if model == YNET else "train_baseline.seed"


def stage_commands(args: argparse.Namespace, scratch: Path) -> list[tuple[str, list[str]]]:
    """(stage, arguments) of the training, then the scoring, every path absolute."""
    ynet_inputs = (args.maps, args.sdd, args.ethucy_scenes) if args.model == YNET else None
    return short_term_commands(args.model, args.dataset, args.windows, scratch, ynet_inputs)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, choices=SHORT_TERM_DATASETS)
    parser.add_argument("--model", required=True, choices=SHORT_TERM_MODELS)
    parser.add_argument("--seed", type=int, required=True, help="training seed")
    parser.add_argument("--windows", type=Path, required=True, help="short_term_windows' folder")
    parser.add_argument("--maps", type=Path, help="Y-net: its scene maps (as train_short_term_ynet)")
    parser.add_argument("--sdd", type=Path, help="Y-net: the fetched SDD root")
    parser.add_argument("--ethucy-scenes", type=Path, help="Y-net: the fetched ETH/UCY images")
    parser.add_argument("--scratch", type=Path, required=True,
                        help="checkpoints and predictions (kept for resuming; not an output)")
    parser.add_argument("--result", type=Path, required=True, help="the run's record (JSON)")
    args = parser.parse_args(argv)
    if args.model == YNET and None in (args.maps, args.sdd, args.ethucy_scenes):
        parser.error("Y-net needs --maps, --sdd and --ethucy-scenes")
    params = read_params()
    scratch = scratch_params(args.scratch.resolve(), params,
                             {seed_key(args.model, active_profile(params)): args.seed})
    started = time.perf_counter()
    for stage, stage_args in stage_commands(args, scratch):
        run_stage(stage, stage_args, scratch)
    record = json.loads((scratch / "run.json").read_text())
    write_json({**record, "training_seed": args.seed, "stage_seconds": time.perf_counter() - started,
                "machine": machine()}, args.result)
    print(f"short_term_seed: {args.dataset} {args.model} seed {args.seed} -> {args.result}")


if __name__ == "__main__":
    main()
