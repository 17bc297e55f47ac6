"""Compares two demo output folders (`harness demo --out DIR`), e.g. before and after a change
that must not move any number: every CSV column of the first folder must be present in the second
with identical text in every row (new columns are allowed and counted); findings.csv rows are
compared whole and each differing row is printed (the wall-clock "computing cost" row always
differs).

    .venv/bin/python harness/studies/compare_demo.py BASELINE_DIR NEW_DIR
"""
import csv
import pathlib
import sys

base, new = map(pathlib.Path, sys.argv[1:3])
problems, extra = [], {}
for b in sorted(base.rglob("*.csv")):
    n = new / b.relative_to(base)
    if not n.exists():
        problems.append(f"missing {n}")
        continue
    with open(b) as fb, open(n) as fn:
        rb, rn = list(csv.reader(fb)), list(csv.reader(fn))
    if b.name == "findings.csv":
        hb = {tuple(r[:2]): r for r in rb}
        hn = {tuple(r[:2]): r for r in rn}
        for key in hb:
            if hb[key] != hn.get(key):
                print("findings row differs:", key, "\n  base:", hb[key], "\n  new: ", hn.get(key))
        continue
    if not rb:
        continue
    cb, cn = rb[0], rn[0]
    idx = {c: i for i, c in enumerate(cn)}
    extra[str(b.relative_to(base))] = len(cn) - len(cb)
    if len(rb) != len(rn):
        problems.append(f"{b.name}: {len(rb)} vs {len(rn)} rows")
        continue
    for j, c in enumerate(cb):
        if c not in idx:
            problems.append(f"{b.name}: column {c} missing")
            continue
        i = idx[c]
        bad = sum(1 for x, y in zip(rb[1:], rn[1:]) if x[j] != y[i])
        if bad:
            problems.append(f"{b.name}: column {c}: {bad} rows differ")
print("CSV files compared:", len(list(base.rglob('*.csv'))))
print("extra columns per file:", sorted(set(extra.values())))
print("problems:", len(problems))
for p in problems[:40]:
    print(" ", p)
sys.exit(1 if problems else 0)
