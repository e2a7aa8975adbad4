#!/usr/bin/env python3
"""Checks that every long option a tool's --help lists appears in its man page source."""
import re
import subprocess
import sys

tool, page = sys.argv[1], sys.argv[2]
help_text = subprocess.run([tool, "--help"], capture_output=True, text=True, check=True).stdout
options = sorted(set(re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", help_text)))
try:
    man = open(page, encoding="utf-8").read()
except OSError:
    print(f"no man page {page}")
    sys.exit(1)
# scdoc escapes nothing in option names, but pages may write \-\- in roff; accept both.
missing = [o for o in options if o not in man and o.replace("-", "\\-") not in man]
if missing:
    print(f"{page}: options in --help but not in the man page: {' '.join(missing)}")
    sys.exit(1)
print(f"{len(options)} options documented")
# --help ends with one example and the man page to read.
tail = help_text.rstrip().split("\n")
name = tool.rsplit("/", 1)[-1]
if tail[-1].strip() != f"More: man {name}" or "Example:" not in help_text or \
        not tail[-3].strip().startswith(("mo-", "candump")):
    print(f"{name} --help does not end with an example and 'More: man {name}':\n" + "\n".join(tail[-5:]))
    sys.exit(1)
