"""Stage `baseline_seed_spread`: per trained long-term baseline and horizon, and for the main Y-net,
the mean and spread of ADE / FDE over training seeds beside the main model's spread over evaluation
rounds (`pipeline.studies.seed_spread`), with every seed's values and kept epoch; Y-net's entry
says why it was not run where the profile trains no extra Y-net seed.

A stage rather than a computation inside the report: the numbers are a result of their own that a
later change (of epoch selection, say) is judged on, diffable in git without rendering the page,
and it reads exactly the seeds `baseline_seeds.extra` and `ynet_seeds.<profile>.seeds` list (a file
left over from an earlier list is never counted; a missing one stops the stage naming it). Params:
`windows.horizons`, `baseline_seeds.extra`, `profile`, `ynet.<profile>.seed` (the main Y-net's
training seed), `ynet_seeds.slots`, `ynet_seeds.<profile>`.

    python -m pipeline.stages.baseline_seed_spread --metrics metrics --out metrics/baseline_seed_spread.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.baseline_seeds import BaselineSeedsParams
from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.windows import WindowParams
from pipeline.config.ynet import ynet_main_seed
from pipeline.config.ynet_seeds import YnetSeedsParams, ynet_seed_slots
from pipeline.studies.seed_spread import YnetSeeds, seed_spread
from pipeline.io import exit_on_bad_intermediate, write_json


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--metrics", type=Path, required=True,
                        help="metrics folder holding baselines/, ynet_seeds/, ynet_eval.json, "
                             "ynet_train.json")
    parser.add_argument("--out", type=Path, required=True, help="JSON written")
    args = parser.parse_args(argv)
    params = read_params()
    horizons = load_section(WindowParams, "windows", params).horizons
    extra = load_section(BaselineSeedsParams, "baseline_seeds", params).extra
    ynet = YnetSeeds(active_profile(params), ynet_main_seed(params), ynet_seed_slots(params),
                     load_profile(YnetSeedsParams, "ynet_seeds", params))
    write_json(seed_spread(args.metrics, horizons, extra, ynet), args.out)


if __name__ == "__main__":
    main()
