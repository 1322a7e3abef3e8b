"""The benchmark pipeline around the `ynet` model library: `config` (every params.yaml section),
`io` (atomic writes), `device` and `preemption` (where torch runs, stopping and resuming), `data`,
`harness`, `runners`, `studies` and `report` (libraries), and `stages` (one thin entry point per dvc.yaml
stage). May import `ynet`, never the reverse; libraries never import `stages`."""
