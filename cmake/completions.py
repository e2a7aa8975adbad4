#!/usr/bin/env python3
"""Writes bash and zsh completions for a tool from its --help (CLI11's format).

usage: completions.py TOOL_BINARY BASH_OUT ZSH_OUT

Options come from the help's option lines ("  -p,--profile FILE REQUIRED  robot profile",
"  --output-format TEXT:{csv,bin}  ..."); an option with a value completes file names when its
value is a FILE, the listed words when CLI11 lists them ({csv,bin}), and nothing otherwise;
words not after an option complete file names (the tools' inputs).
"""
import re
import subprocess
import sys

OPTION = re.compile(r"^\s{2}(-[A-Za-z0-9],)?(--[a-z][a-z0-9-]*|-[A-Za-z0-9](?=[ ,]|$))(.*)$")


def parse(help_text):
    options = []
    for line in help_text.split("\n"):
        m = OPTION.match(line)
        if not m:
            continue
        names = [n.rstrip(",") for n in (m.group(1), m.group(2)) if n]
        rest = m.group(3)
        parts = re.split(r"\s{2,}", rest.strip(), maxsplit=1)
        value = parts[0] if rest.startswith(" ") and not rest.startswith("  ") else ""
        description = parts[-1] if len(parts) > 1 or not value else ""
        value = re.sub(r"\s*REQUIRED.*$|\s*(Excludes|Needs):.*$", "", value)
        choices = []
        c = re.search(r"\{([^}]*)\}", value)
        if c:
            choices = [w.strip() for w in c.group(1).split(",") if w.strip()]
        kind = "none"
        if value:
            kind = "choices" if choices else ("file" if value.startswith(("FILE", "DIR", "PATH")) else "value")
        options.append({"names": names, "kind": kind, "choices": choices, "description": description.strip()})
    return options


def bash(tool, options):
    function = "_" + tool.replace("-", "_")
    words = " ".join(n for o in options for n in o["names"])
    cases = []
    files = [n for o in options if o["kind"] == "file" for n in o["names"]]
    if files:
        cases.append(f"    {'|'.join(files)})\n      COMPREPLY=($(compgen -f -- \"$cur\"))\n      return ;;")
    for o in options:
        if o["kind"] == "choices":
            cases.append(f"    {'|'.join(o['names'])})\n      COMPREPLY=($(compgen -W \"{' '.join(o['choices'])}\" -- \"$cur\"))\n      return ;;")
    values = [n for o in options if o["kind"] == "value" for n in o["names"]]
    if values:
        cases.append(f"    {'|'.join(values)})\n      return ;;")
    case_block = "  case $prev in\n" + "\n".join(cases) + "\n  esac\n" if cases else ""
    return f"""# bash completion for {tool} (generated from {tool} --help by momentum's cmake/completions.py)
{function}() {{
  local cur=${{COMP_WORDS[COMP_CWORD]}} prev=${{COMP_WORDS[COMP_CWORD-1]}}
  COMPREPLY=()
{case_block}  if [[ $cur == -* ]]; then
    COMPREPLY=($(compgen -W "{words}" -- "$cur"))
  else
    COMPREPLY=($(compgen -f -- "$cur"))
  fi
}}
complete -o filenames -F {function} {tool}
"""


def zsh_text(text):
    return re.sub(r"[\[\]:'\\]", " ", text).strip()


def zsh(tool, options):
    specs = []
    for o in options:
        description = zsh_text(o["description"])
        if o["kind"] == "file":
            action = ":file:_files"
        elif o["kind"] == "choices":
            action = ":value:(" + " ".join(o["choices"]) + ")"
        elif o["kind"] == "value":
            action = ":value: "
        else:
            action = ""
        names = o["names"]
        if len(names) == 1:
            specs.append(f"'{names[0]}[{description}]{action}'")
        else:
            exclusive = " ".join(names)
            specs.append(f"'({exclusive})'{{{','.join(names)}}}'[{description}]{action}'")
    specs.append("'*:file:_files'")
    body = " \\\n  ".join(specs)
    return f"""#compdef {tool}
# zsh completion for {tool} (generated from {tool} --help by momentum's cmake/completions.py)
_arguments -s \\
  {body}
"""


def main():
    binary, bash_out, zsh_out = sys.argv[1:4]
    tool = binary.rsplit("/", 1)[-1]
    help_text = subprocess.run([binary, "--help"], capture_output=True, text=True, check=True).stdout
    options = parse(help_text)
    if not options:
        sys.exit(f"completions.py: no options found in {tool} --help")
    open(bash_out, "w").write(bash(tool, options))
    open(zsh_out, "w").write(zsh(tool, options))


if __name__ == "__main__":
    main()
