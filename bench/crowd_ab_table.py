"""The table of a crowd benchmark that puts two builds side by side (bench/crowd_ab.sh): the run and the command from
the CSV's head, a note, then for each scenario (if the CSV has one) and build the median over rounds of every column,
each round's value in brackets. KEYS (comma-separated columns) groups the rows by other columns instead (in their
order; numbers sorted as numbers).

    python3 bench/crowd_ab_table.py CSV TITLE NOTE [KEYS] > MD
"""
import collections
import csv
import statistics
import sys

path, title, note = sys.argv[1:4]
lines = open(path).read().splitlines()
head = [line[2:] for line in lines if line.startswith('# ')]
rows = list(csv.DictReader(line for line in lines if not line.startswith('#')))
keys = sys.argv[4].split(',') if len(sys.argv) > 4 else [k for k in ('scenario', 'build') if rows and k in rows[0]]
cols = [c for c in (rows[0] if rows else {}) if c not in keys and c != 'round']
print(f'# {title}\n')
print(f'- Run: {head[0]}')
print(f'- Command: `{head[1]}`')
print(f'- Each row: the median over rounds (each round\'s value in brackets). {note}\n')
print('| ' + ' | '.join(keys + cols) + ' |')
print('|' + '---|' * len(keys) + '---:|' * len(cols))
groups = collections.defaultdict(list)
for r in rows:
    groups[tuple(r[k] for k in keys)].append(r)
def order(key):
    """Old before new; numbers as numbers."""
    def cell(v):
        try:
            return (0, float(v), '')
        except ValueError:
            return (1, 0, v)
    return tuple(cell(v) for v in key[:-1]) + ((key[-1] != 'old', ) if key[-1] in ('old', 'new') else cell(key[-1]))


for key in sorted(groups, key=order):
    cells = []
    for c in cols:
        v = [float(r[c]) for r in groups[key] if r[c] not in ('', 'nan')]
        cells.append(f"{statistics.median(v):g} ({', '.join(f'{x:g}' for x in v)})" if v else '')
    print('| ' + ' | '.join(list(key) + cells) + ' |')
