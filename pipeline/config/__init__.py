"""Typed access to `params.yaml`: one module per section, named after it (`pipeline.config.ttst`
for section `ttst`, ...), holding that section's dataclass with its docstrings and checks, and
`pipeline.config.loading` for what every section shares (`read_params`, `load_section`,
`load_profile`, `ParamsError`).

Import a section from its own module, never from this package: a stage's code (its fingerprint,
`pipeline.code_graph`) then holds only the sections it reads, so editing one section re-runs only
the stages that read it (`tests/test_config_sections.py`). This file holds no code for the same
reason.
"""
