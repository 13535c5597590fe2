#!/usr/bin/env python3
"""Put a generated section into a Markdown document between its markers.

    python3 scripts/splice_section.py NAME TARGET DOC SECTION [--trim]

Replaces the lines of DOC from `<!-- NAME:begin (TARGET) -->` through `<!-- NAME:end -->` by those
markers around a blank line and the text of the file SECTION (appended after a blank line the
first time, when DOC lacks the markers). `--trim` ends the section with exactly one blank line.
DOC is replaced atomically (written beside it, then renamed). The table scripts
(`scripts/real_table.sh`, `scripts/study_denoise.sh`) call it.
"""
import os
import sys


def main(argv):
    trim = "--trim" in argv
    args = [a for a in argv if a != "--trim"]
    if len(args) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    name, target, path, section_path = args
    with open(section_path) as f:
        section = f.read()
    if trim:
        section = section.rstrip("\n") + "\n\n"
    with open(path) as f:
        text = f.read()
    begin, end = f"<!-- {name}:begin ({target}) -->\n", f"<!-- {name}:end -->\n"
    block = begin + "\n" + section + end
    if begin in text and end in text:
        a, b = text.index(begin), text.index(end) + len(end)
        text = text[:a] + block + text[b:]
    else:
        text = text.rstrip("\n") + "\n\n" + block
    with open(path + ".tmp", "w") as f:
        f.write(text)
    os.replace(path + ".tmp", path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
