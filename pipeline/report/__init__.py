"""Report: the HTML page with the paper's numbers beside ours (`page`), its jinja2 template
(`templates/`) and the paper's values (`paper_values.yaml`)."""
