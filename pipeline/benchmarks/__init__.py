"""One module per benchmark, each a `pipeline.benchmarks.base.Benchmark` with its loading, unit,
scales, masks, windows and the settings it overrides; `pipeline.benchmarks.registry` lists them.
"""
