#!/usr/bin/env python3
"""The README's parameter table must agree with the presets: every row's key exists in both presets and its
indoor/outdoor defaults are the presets' values. Exits non-zero, naming each disagreement."""
import os
import sys

import yaml

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def preset(name):
    with open(os.path.join(ROOT, "config", name)) as f:
        return yaml.safe_load(f)


def value(config, key):
    section, name = key.split(".")
    return config[section][name]


def same(text, actual):
    if isinstance(actual, bool):
        return text == ("true" if actual else "false")
    if isinstance(actual, (int, float)):
        try:
            return float(text) == float(actual)
        except ValueError:
            return False
    return text == str(actual)


def main():
    presets = {"indoor": preset("indoor_rgbd.yaml"), "outdoor": preset("outdoor_lidar.yaml")}
    with open(os.path.join(ROOT, "README.md")) as f:
        readme = f.read()
    section = readme[readme.index("## Parameters"):]
    section = section[:section.index("\n## ", 1)]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    problems = []
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        key = cells[0].strip("`")
        for column, name in ((2, "indoor"), (3, "outdoor")):
            try:
                actual = value(presets[name], key)
            except (KeyError, ValueError):
                problems.append("%s: not in the %s preset" % (key, name))
                continue
            if not same(cells[column], actual):
                problems.append("%s: README says %s for %s, the preset has %r" % (key, cells[column], name, actual))
    for p in problems:
        print("README parameter table:", p)
    print("%d rows checked, %d disagreements" % (len(rows), len(problems)))
    return 1 if problems or not rows else 0


if __name__ == "__main__":
    sys.exit(main())
