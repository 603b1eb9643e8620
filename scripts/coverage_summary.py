#!/usr/bin/env python3
"""Line coverage per folder from `llvm-cov export -summary-only` JSON.

    coverage_summary.py SUMMARY.json REPO_ROOT

Folders come from the files' paths (src/ and whatever folders it grows, capi/,
tools/ and theirs); every file of the repository under src/, capi/ or tools/
that the binaries hold counts, tests/, fuzz/ and system headers do not. Prints
one row per folder, a row per top-level folder, the src/ + capi/ line the
issue's goal is about, and a total."""
import json
import os
import sys
from collections import defaultdict

TOP = ('src', 'capi', 'tools')


def main():
    summary, root = sys.argv[1], os.path.realpath(sys.argv[2])
    with open(summary) as f:
        data = json.load(f)
    per_dir = defaultdict(lambda: [0, 0])  # folder -> [covered, count]
    for export in data['data']:
        for fe in export['files']:
            path = os.path.realpath(fe['filename'])
            if not path.startswith(root + os.sep):
                continue
            rel = os.path.relpath(path, root)
            if rel.split(os.sep)[0] not in TOP:
                continue
            lines = fe['summary']['lines']
            d = per_dir[os.path.dirname(rel)]
            d[0] += lines['covered']
            d[1] += lines['count']

    def row(name, cov, count):
        pct = 100.0 * cov / count if count else 0.0
        print('%-24s %8d %8d %7.1f%%' % (name, cov, count, pct))

    print('%-24s %8s %8s %8s' % ('folder', 'covered', 'lines', 'cover'))
    tops = defaultdict(lambda: [0, 0])
    for folder in sorted(per_dir):
        cov, count = per_dir[folder]
        row(folder + '/', cov, count)
        t = tops[folder.split(os.sep)[0]]
        t[0] += cov
        t[1] += count
    print('-' * 51)
    for top in TOP:
        if top in tops and any(os.sep in f for f in per_dir if f.split(os.sep)[0] == top):
            row(top + '/ (all)', *tops[top])
    sc = [tops['src'][0] + tops['capi'][0], tops['src'][1] + tops['capi'][1]]
    row('src/ + capi/', *sc)
    row('total', sum(t[0] for t in tops.values()), sum(t[1] for t in tops.values()))


if __name__ == '__main__':
    main()
