#!/usr/bin/env python3
"""Compares the non-timing columns of two `shvis bench` table.json files, row by row.

Usage: scripts/compare_tables.py BEFORE/table.json AFTER/table.json
"""
import json, sys
a = json.load(open(sys.argv[1])); b = json.load(open(sys.argv[2]))
cols = ["rel_rmse", "psnr", "texel_bytes", "table_bytes", "textures_bound", "lookups_per_pixel", "reference", "paper_ms", "paper_ratio_to_preconv", "frames"]
ka = {(r["technique"], r["path"]): r for r in a["results"]}
kb = {(r["technique"], r["path"]): r for r in b["results"]}
assert ka.keys() == kb.keys(), (set(ka) ^ set(kb))
worst = {}
for k in ka:
    for c in cols:
        x, y = ka[k][c], kb[k][c]
        if isinstance(x, (int, float)) and isinstance(y, (int, float)):
            d = abs(x - y)
        else:
            d = 0 if x == y else float("inf")
        if d > worst.get(c, (0, None))[0]:
            worst[c] = (d, k, x, y)
print(f"{len(ka)} rows compared")
for c in cols:
    w = worst.get(c)
    print(f"{c:24s} largest difference: " + ("0 (identical)" if not w else f"{w[0]:.3g} at {w[1][0]}.{w[1][1]} ({w[2]} -> {w[3]})"))
print(f"{'table_version':24s} {a.get('table_version')} -> {b.get('table_version')}")
for f in ["reference_rel_noise", "reference_bounced_rel_noise", "reference_bounces", "vis_res", "width", "height"]:
    print(f"{f:24s} {a[f]} -> {b[f]}")
