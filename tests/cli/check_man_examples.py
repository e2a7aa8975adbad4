#!/usr/bin/env python3
"""Checks that a man page's examples survive being pasted from an 80-column terminal.

usage: check_man_examples.py PAGE.scd BUILT_PAGE

1. A command shown in a tab-indented paragraph is filled by man (wrapped, even hyphenated) and
   fails when pasted: commands must be in literal blocks (```).
2. scdoc takes a backslash as an escape, also in a literal block: a command's continuation
   "\\" at the end of a line vanishes from the page (the pasted command then stops at that
   line), and "\\n" in a printf shows as "n". A literal block writes a backslash as two.
3. Rendered at 80 columns (groff -man -Tutf8 -rLL=80n, as man does with MANWIDTH=80), no line
   may be wider than 80 characters: a long literal line runs past the terminal's edge and is
   wrapped by it. Exempt: sample outputs a tool really prints wider (listed below by their
   first words); the commands that print them are still checked.
"""
import re
import subprocess
import sys

COMMAND = re.compile(
    r"^\t(mo-[a-z0-9-]+(\s|$)|candump\s|cansend\s|cp\s|[A-Z]=|\.\.\. \||for\s|systemctl\s|"
    r"sudo\s|cmake\s|jq\s|python3\s|awk\s|mkdir\s|echo\s|cd\s)")
WIDE_OUTPUT = ("signal joint state", "mu     1", "t_onset_estimate,t_detect", "mo-observe: warning:")


def main():
    source, built = sys.argv[1], sys.argv[2]
    problems = []
    literal = False
    previous = ""
    for number, line in enumerate(open(source, encoding="utf-8").read().split("\n"), 1):
        if line.strip().startswith("```"):
            literal = not literal
        elif literal and "\\" in line.replace("\\\\", ""):
            problems.append(f"{source}:{number}: a single backslash in a literal block vanishes (write two): {line.strip()}")
        elif not literal and previous.strip() == "" and COMMAND.match(line):
            problems.append(f"{source}:{number}: a command in a filled paragraph (put it in a ``` block): {line.strip()}")
        previous = line
    rendered = subprocess.run(["groff", "-t", "-man", "-Tutf8", "-rLL=80n", built],
                              check=True, capture_output=True).stdout.decode("utf-8")
    rendered = re.sub(r".\x08", "", rendered)
    for line in rendered.split("\n"):
        line = line.expandtabs(8).rstrip()
        if len(line) > 80 and not line.strip().startswith(WIDE_OUTPUT):
            problems.append(f"{built}: {len(line)} columns at 80: {line.strip()}")
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
