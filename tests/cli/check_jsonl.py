#!/usr/bin/env python3
"""Checks JSON Lines output against the keys a man page documents.

usage: check_jsonl.py PAGE.scd [FILE]      (FILE default: stdin)

The page's JSON LINES section lists the keys of each kind of line, each list introduced by a
paragraph starting "Keys" and made of items "- *key* ...". Every input line must parse with
json.loads as an object whose keys are exactly one of the documented lists. Prints the number
of lines and, per list, how many lines matched it.
"""
import json
import re
import sys

page = open(sys.argv[1], encoding="utf-8").read()
section = re.search(r"^# JSON LINES\n(.*?)(?=^# |\Z)", page, re.S | re.M)
if not section:
    sys.exit(f"{sys.argv[1]}: no JSON LINES section")
schemas, current = [], None
for line in section.group(1).split("\n"):
    if line.startswith("Keys"):
        current = []
        schemas.append((line.strip(), current))
    elif current is not None and re.match(r"^- \*[a-z_0-9]+\*", line):
        # "- *t_first*, *t_last* (numbers, s)": the names before the description.
        head = re.split(r" \(|: ", line, maxsplit=1)[0]
        current.extend(re.findall(r"\*([a-z_0-9]+)\*", head))
    elif current is not None and line and not line.startswith((" ", "\t", "-")):
        current = None
schemas = [(title, set(keys)) for title, keys in schemas if keys]
if not schemas:
    sys.exit(f"{sys.argv[1]}: no key lists in JSON LINES")
text = open(sys.argv[2]).read() if len(sys.argv) > 2 else sys.stdin.read()
lines = text.split("\n")
if lines and lines[-1] == "":
    lines.pop()
counts = [0] * len(schemas)
for number, line in enumerate(lines, 1):
    try:
        value = json.loads(line)
    except json.JSONDecodeError as e:
        sys.exit(f"line {number}: not JSON: {e}: {line[:80]}")
    if not isinstance(value, dict):
        sys.exit(f"line {number}: not an object")
    matches = [k for k, (_, keys) in enumerate(schemas) if set(value) == keys]
    if not matches:
        best = min(schemas, key=lambda s: len(s[1] ^ set(value)))
        sys.exit(f"line {number}: keys {sorted(value)} are not a documented list; closest ({best[0]}) "
                 f"differs by {sorted(best[1] ^ set(value))}")
    counts[matches[0]] += 1
print(f"{len(lines)} lines, keys as documented: " + ", ".join(
    f"{n} x {title.rstrip(':')}" for (title, _), n in zip(schemas, counts)))
