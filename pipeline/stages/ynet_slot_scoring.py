"""Stage `ynet_slot_scoring`: how each Y-net horizon and extra-seed slot is scored, one file a slot.

Writes `<out>/<slot>.json` for every `evaluate_ynet_horizon@<t_f>` (slot `tf<t_f>`) and
`evaluate_ynet_seed@<seed>` (slot `seed<seed>`): the sampling settings of a slot the active profile
trains, `{slot, scored: false}` for the others (`pipeline.runners.slot_scoring`). The evaluation stages
depend on their own file instead of the sampling params, so a slot the profile does not train is
not re-run by `dvc exp run -S ttst.temperature=...`. Params: `profile`, `ttst`, `cws`,
`eval.<profile>` (k_e, k_a, rounds, seed, batch_size, chunk_size, bf16, threads),
`ynet_horizons.<profile>` (epochs, rounds), `ynet_seeds.slots`, `ynet_seeds.<profile>.seeds`,
`windows.horizons`, `windows.release_horizon`.

    python -m pipeline.stages.ynet_slot_scoring --out data/ynet_slot_scoring
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pipeline.config.cws import CwsParams
from pipeline.config.eval import EvalParams
from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.ttst import TtstParams
from pipeline.config.ynet_horizons import HorizonParams
from pipeline.config.ynet_seeds import YnetSeedsParams, ynet_seed_slots
from pipeline.io import atomic_dir, write_json
from pipeline.runners.slot_scoring import SlotSettings, slot_payloads


def slot_settings(params: dict[str, Any]) -> SlotSettings:
    """What the slots are resolved from, read from `params` (params.yaml as read); `windows` as
    written (only its horizons: the stage declares no other key of it)."""
    windows = params.get("windows", {})
    return SlotSettings(
        active_profile(params), windows.get("horizons"), windows.get("release_horizon"),
        load_profile(EvalParams, "eval", params), load_section(TtstParams, "ttst", params),
        load_section(CwsParams, "cws", params), load_profile(HorizonParams, "ynet_horizons", params),
        load_profile(YnetSeedsParams, "ynet_seeds", params).seeds, ynet_seed_slots(params))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    payloads = slot_payloads(slot_settings(read_params()))
    with atomic_dir(args.out, mode=0o755) as tmp:
        for slot, payload in payloads.items():
            write_json(payload, tmp / f"{slot}.json", sort_keys=True)
    scored = [slot for slot, payload in payloads.items() if payload["scored"]]
    print(f"ynet_slot_scoring: {len(payloads)} slots, scored: {', '.join(scored) or 'none'}")


if __name__ == "__main__":
    main()
