#!/usr/bin/env python3
"""check_squeezed.py STATS.json... — exits 1 unless every render's --stats shows a frame whose
patches did not fit: at least one eviction, and some but not all dicings built without their
vertices (counters patch_cache_evictions, grids_skipped, patches_diced). The checks that render
a squeezed frame on purpose (tools/check_kernels.sh under Oclgrind, tests/check_rusticl.sh on
Mesa) run it, so that a change which made their frame fit fails them instead of silently
checking a frame that fits."""
import json
import sys

if len(sys.argv) < 2:
    sys.exit("usage: check_squeezed.py STATS.json...")
failed = False
for path in sys.argv[1:]:
    c = json.load(open(path))["counters"]
    if not (c["patch_cache_evictions"] > 0 and 0 < c["grids_skipped"] < c["patches_diced"]):
        print(f"check_squeezed: {path}: the frame fits ({c['patch_cache_evictions']} evictions, "
              f"{c['grids_skipped']} of {c['patches_diced']} dicings without vertices)")
        failed = True
sys.exit(1 if failed else 0)
