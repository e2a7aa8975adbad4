"""Alters a mo-sim log on purpose, as a wrong setup would: alter.py KIND IN OUT.
sign: joint 2's current negated (a torque constant of the wrong sign); ma: joint 3's current
x1000 (mA); swap: joints 2 and 3's columns swapped (q, dq, i); degrees: every q and dq in
degrees; qdeg: q in degrees, dq in rad/s; zero: the columns numbered from 0."""
import math
import sys

kind, source, target = sys.argv[1:4]
lines = [l for l in open(source).read().splitlines() if not l.startswith('#')]
header = lines[0].split(',')
rows = [[float(x) for x in l.split(',')] for l in lines[1:]]
col = {name: k for k, name in enumerate(header)}
for r in rows:
    if kind == 'sign':
        r[col['i2']] = -r[col['i2']]
    elif kind == 'ma':
        r[col['i3']] *= 1000
    elif kind == 'swap':
        for p in ('q', 'dq', 'i'):
            a, b = col[p + '2'], col[p + '3']
            r[a], r[b] = r[b], r[a]
    elif kind in ('degrees', 'qdeg'):
        for name, k in col.items():
            if name.startswith('q') or (kind == 'degrees' and name.startswith('dq')):
                r[k] = math.degrees(r[k])
if kind == 'zero':
    header = [h[:-1] + str(int(h[-1]) - 1) if h[-1].isdigit() else h for h in header]
with open(target, 'w') as out:
    out.write(','.join(header) + '\n')
    for r in rows:
        out.write(','.join(repr(x) for x in r) + '\n')
