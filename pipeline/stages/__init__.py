"""Stages: one thin module per dvc.yaml stage, named as the stage, each run as
`python -m pipeline.stages.<name>`: parse arguments, read params.yaml once, call the libraries,
write the declared outputs. No stage imports another, and no library imports a stage."""
