#!/usr/bin/env python3
"""The README's parameter table must agree with the presets: every row's key exists in both presets and its
indoor/outdoor defaults are the presets' values. The Luminar preset has the outdoor one's keys, and the
README's sentence on it names every value where the two differ. (The README's table of the node's own parameters
is checked against the node's parameter table by test/ros/test_node_parameters.cpp.) Exits non-zero, naming each disagreement; with
--xunit PATH it also writes the outcome as a JUnit report (what catkin_test_results reads)."""
import argparse
import os
import re
import sys
from xml.sax.saxutils import escape

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


def flattened(config, prefix=""):
    items = {}
    for key, value in config.items():
        if isinstance(value, dict):
            items.update(flattened(value, prefix + key + "."))
        else:
            items[prefix + key] = value
    return items


def luminar_problems(readme, outdoor):
    """The Luminar preset against the outdoor one and the README's sentence on it."""
    luminar, outdoor = flattened(preset("luminar_lidar.yaml")), flattened(outdoor)
    problems = ["%s: in the outdoor preset, not in the Luminar one" % k for k in sorted(set(outdoor) - set(luminar))]
    problems += ["%s: in the Luminar preset, not in the outdoor one" % k for k in sorted(set(luminar) - set(outdoor))]
    sentence = next((line for line in readme.split("\n\n") if line.startswith("`config/luminar_lidar.yaml`")), "")
    named = dict(re.findall(r"`([a-z_]+\.[a-z_]+)` ([0-9.]+)", sentence))
    for key in sorted(set(luminar) & set(outdoor)):
        if luminar[key] != outdoor[key] and key not in named:
            problems.append("%s: the Luminar preset has %r (outdoor %r), the README does not say" %
                            (key, luminar[key], outdoor[key]))
    for key, text in named.items():
        if key not in luminar or not same(text, luminar[key]):
            problems.append("%s: README says %s for the Luminar preset, it has %r" % (key, text, luminar.get(key)))
    return problems


def write_xunit(path, problems):
    failure = ""
    if problems:
        failure = '<failure message="README parameter table">%s</failure>' % escape("\n".join(problems))
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        f.write('<?xml version="1.0" encoding="UTF-8"?>\n'
                '<testsuite name="readme_parameter_table" tests="1" failures="%d" errors="0">'
                '<testcase classname="docs" name="readme_parameter_table">%s</testcase></testsuite>\n'
                % (1 if problems else 0, failure))


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--xunit", help="also write a JUnit report here")
    args = parser.parse_args()
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
    if not rows:
        problems.append("no parameter rows found under '## Parameters'")
    problems += luminar_problems(section, presets["outdoor"])
    for p in problems:
        print("README parameter table:", p)
    if args.xunit:
        write_xunit(args.xunit, problems)
    print("%d rows checked, %d disagreements" % (len(rows), len(problems)))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
