#!/usr/bin/env python3
"""help_options.py SOURCE TESSERA — every long option that `tessera render` and `tessera bake`
accept (the getopt_long tables in host/app/options.c and host/app/bake_options.c) is named
in `tessera --help` as "--NAME", and every "--NAME" that --help names is one they accept.
Exit status 0, or 1 with each option missing on one side."""
import re
import subprocess
import sys

source, tessera = sys.argv[1], sys.argv[2]
accepted = set()
for f in ("host/app/options.c", "host/app/bake_options.c"):
    text = open(f"{source}/{f}", encoding="utf-8").read()
    table = re.search(r"struct option \w+\[\] = \{(.*?)\n\};", text, re.S)
    accepted |= set(re.findall(r'\{"([a-z-]+)",', table.group(1)))
out = subprocess.run([tessera, "--help"], capture_output=True, text=True, check=True).stdout
named = set(re.findall(r"(?<![\w-])--([a-z][a-z-]*)", out))
bad = [f"--{o}: accepted but not in --help" for o in sorted(accepted - named)]
bad += [f"--{o}: in --help but not accepted" for o in sorted(named - accepted)]
print("\n".join(bad + [f"help_options: {len(accepted)} options, {len(bad)} mismatches"]))
sys.exit(1 if bad or len(accepted) < 20 else 0)
