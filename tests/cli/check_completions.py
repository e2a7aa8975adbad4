#!/usr/bin/env python3
"""Checks a tool's installed shell completions against its --help.

usage: check_completions.py TOOL_BINARY BASH_FILE ZSH_FILE

bash: with the completion loaded, every long option of --help completes from its first three
letters after a dash-dash, -p/--profile (a FILE) completes a file name, and an option whose
values --help lists ({csv,bin}) completes them. zsh: the file parses (zsh -n) and names every option.
"""
import os
import re
import subprocess
import sys
import tempfile

binary, bash_file, zsh_file = (os.path.abspath(p) for p in sys.argv[1:4])
tool = os.path.basename(binary)
help_text = subprocess.run([binary, "--help"], capture_output=True, text=True, check=True).stdout
options = sorted(set(re.findall(r"^\s{2}(?:-\w,)?(--[a-z][a-z0-9-]*)", help_text, re.M)))
problems = []


def complete(words, cwd):
    """Runs the bash completion function on the command line `words` (last one being typed)."""
    script = f"""
source {bash_file}
COMP_WORDS=({' '.join("'" + w + "'" for w in words)})
COMP_CWORD={len(words) - 1}
spec=$(complete -p {tool})
fn=${{spec#*-F }}; fn=${{fn%% *}}
$fn
printf '%s\\n' "${{COMPREPLY[@]}}"
"""
    return subprocess.run(["bash", "-c", script], capture_output=True, text=True, cwd=cwd).stdout.split()


with tempfile.TemporaryDirectory() as d:
    open(os.path.join(d, "arm-profile.json"), "w").close()
    for option in options:
        got = complete([tool, option[:5]], d)
        if option not in got:
            problems.append(f"bash: {option[:5]} does not complete to {option} (got {got})")
    if "--profile" in options and "arm-profile.json" not in complete([tool, "--profile", "arm"], d):
        problems.append("bash: --profile does not complete a file name")
    # An option whose values --help lists ("--output-format TEXT:{csv,bin}") completes them.
    for option, words in re.findall(r"^\s{2}(?:-\w,)?(--[a-z][a-z0-9-]*) \S*\{([^}]*)\}", help_text, re.M):
        expected = sorted(w.strip() for w in words.split(","))
        got = sorted(complete([tool, option, ""], d))
        if got != expected:
            problems.append(f"bash: {option} completes {got}, not {expected}")

zsh = subprocess.run(["zsh", "-n", zsh_file], capture_output=True, text=True)
if zsh.returncode != 0:
    problems.append(f"zsh: {zsh_file} does not parse: {zsh.stderr.strip()}")
text = open(zsh_file).read()
if not text.startswith(f"#compdef {tool}\n"):
    problems.append("zsh: no #compdef line")
for option in options:
    if option not in text:
        problems.append(f"zsh: {option} missing")
for p in problems:
    print(p)
print(f"{tool}: {len(options)} options complete in bash and zsh" if not problems else "")
sys.exit(1 if problems else 0)
