#!/bin/sh
# Regenerates every number in report.md (seed 20240607 everywhere; ~10 min on 1-2 cores).
set -e
cd "$(dirname "$0")"
PY=${PY:-python3}  # numpy needed
$PY implied_c.py > implied_c.md      # part 1: implied c per printed value
$PY mc_floor.py                      # iid floors of all candidates -> floor.csv
$PY pivot.py > pivot.txt
$PY ctable.py > ctable.md
$PY mc_meanbins.py > meanbins.txt    # "mean over bins" variants
$PY mc_grid.py > grid.txt            # global fixed grid
$PY mc_worst.py > worst.txt          # Table 2 worst-minus-mean -> worst.csv
$PY mc_order.py > order.txt          # Table 1 4th- vs 2nd-order difference
$PY mc_block.py                      # correlated 8x8 block, generators -> block.csv
$PY mc_gen.py                        # generation-aware floors -> gen.csv
$PY fit.py > fit_stdout.txt          # rankings -> fit_iid.txt, fit_gen_*.txt
$PY cand.py > cand.txt               # short list, fixed scale
$PY bias.py > bias.txt               # bias corrections -> bias.csv
