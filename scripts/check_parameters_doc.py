#!/usr/bin/python3
"""Checks docs/parameters.md against config/*.yaml: each core's table lists exactly the keys of
its YAML file, with the same defaults. The YAML files are kept equal to the code's defaults by the
unit test test_config_defaults, so the page cannot drift from the code unnoticed.

Usage: scripts/check_parameters_doc.py   (exit 1 with the differences; CI runs it)
"""
import os
import re
import sys

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "parameters.md")
SECTIONS = {"mask": "Parameters of the mask core", "tracking": "Parameters of the tracking core",
            "mapping": "Parameters of the mapping core"}


def doc_table(text, heading):
    """{parameter: default text} of the first table after the heading that starts with `heading`."""
    start = text.find("### " + heading)
    if start < 0:
        sys.exit(f"check_parameters_doc: no '### {heading}' in {DOC}")
    rows = {}
    for line in text[start:].splitlines()[1:]:
        if line.startswith("#"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 3 and cells[0].startswith("`"):
            rows[cells[0].strip("`")] = cells[2].strip("`")
    return rows


def same(doc_value, yaml_value):
    if isinstance(yaml_value, bool):
        return doc_value.lower() == str(yaml_value).lower()
    if isinstance(yaml_value, (int, float)):
        try:
            return float(doc_value) == float(yaml_value)
        except ValueError:
            return False
    if isinstance(yaml_value, list):
        return [s.strip() for s in doc_value.strip("[]").split(",") if s.strip()] == [str(v) for v in yaml_value]
    return doc_value.strip('"') == str(yaml_value)


def main():
    if any(a in ("-h", "--help") for a in sys.argv[1:]):
        print(__doc__.strip())
        return 0
    text = open(DOC).read()
    problems = []
    for module, heading in SECTIONS.items():
        config = yaml.safe_load(open(os.path.join(ROOT, "config", module + ".yaml"))) or {}
        rows = doc_table(text, heading)
        for key in config.keys() - rows.keys():
            problems.append(f"{module}: {key} is in config/{module}.yaml but not in the docs")
        for key in rows.keys() - config.keys():
            problems.append(f"{module}: {key} is in the docs but not in config/{module}.yaml")
        for key in config.keys() & rows.keys():
            if not same(rows[key], config[key]):
                problems.append(f"{module}: {key}: docs say {rows[key]!r}, config/{module}.yaml {config[key]!r}")
    for p in problems:
        print("check_parameters_doc: " + p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
