#!/usr/bin/env python3
"""window_cases.py N SEED [MAX] - N window texts, one a line: the edge cases,
then random windows of 1 or 3 channels (every black/white pair up to MAX,
default 255, is reachable, gammas 0.1 .. 10 with 0 to 3 decimals), then
malformed texts."""
import random
import sys

n, seed = int(sys.argv[1]), int(sys.argv[2])
vmax = int(sys.argv[3]) if len(sys.argv) > 3 else 255
rnd = random.Random(seed)
fixed = ['0,255', '0,255,1', '0,2,1', '0,1,0.1', '254,255,10', '0,255,0.5',
         '0,255,2', '1,3,1', '10,200,2.2', '0,254,1.999', '0,3,0.333',
         '0,255,1;0,128,0.5;64,255,3.125', '0,255,10.000', '0,255,0.100']
bad = ['', ',', '5,5,1', '6,5,1', '0,256,1', '-1,255,1', '+1,255,1',
       '0,255,1e1', '0,255,.5', '0,255,1.', '0,255,1.2345', '0,255,0.099',
       '0,255,10.001', '0,255,11', '0,255,1;', ' 0,255,1', '0,255,1,1',
       ';'.join(['0,255,1'] * 9), '0,255,nan', '0x1,255,1']


def gamma():
    d = rnd.choice([0, 1, 2, 3])
    g = rnd.randint(100, 10000) // 10 ** (3 - d) * 10 ** (3 - d)
    g = max(g, 100 if d else 1000)
    return f'{g // 1000}' + (f'.{g % 1000:03d}'[:d + 1] if d else '')


def one():
    b = rnd.randint(0, vmax - 1)
    w = rnd.randint(b + 1, vmax)
    return f'{b},{w},{gamma()}'


out = list(fixed)
if vmax > 255:
    out += [f'0,{vmax},1', f'{vmax - 1},{vmax},1', f'1000,{vmax},0.45', '0,1,1', f'0,{vmax},0.1']
while len(out) < n:
    out.append(one() if rnd.random() < 0.7 else ';'.join(one() for _ in range(3)))
out += bad
print('\n'.join(out))
