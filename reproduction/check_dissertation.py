#!/usr/bin/env python3
"""Check the shape of reproduction/dissertation.yaml (the dissertation's tables as printed).

Usage: python3 reproduction/check_dissertation.py [path/to/dissertation.yaml]

Shape checks (failures make the exit status 1):
  - tables numbered 1..36, each exactly once, in order;
  - each table has number, title, section, kind, setting, unit, rows, columns, values;
  - kind is "result" or "description";
  - rows and columns are lists of strings; values has one list per row, each with
    len(columns) entries; every entry is a number, a string or null;
  - the optional figures list has figure, section, quantity, value, unit, quote, the quote
    under 25 words.
Consistency checks between tables that print the same quantities (also failures): the
summaries of Tables 6 and 11 against the per-direction rows of Tables 26/28 and 30-36,
Tables 7 and 12 against Tables 25/27 and 29/31/33/35, Table 4's D against H*V. Two
disagreements printed in the dissertation itself (Table 11 against Tables 30 and 32) are listed
in KNOWN_MISMATCHES and reported without failing.
"""
import sys
from pathlib import Path

import yaml

REQUIRED = ("number", "title", "section", "kind", "setting", "unit", "rows", "columns", "values")
OPTIONAL = ("row_header", "notes")
FIGURE_REQUIRED = ("figure", "section", "quantity", "value", "unit", "quote")
DESCRIPTIONS = {5, 17, 18, 19, 21, 23}

errors = []
notes = []

# Disagreements printed in the dissertation itself (see the tables' notes): reported, not failed.
KNOWN_MISMATCHES = {
    (11, "Plant D, Light Wind", "Method 1", "Level 1-3"),   # 0.2000 vs 0.1997 from Table 30
    (11, "Plant D, Medium Wind", "Method 2", "Level 1-3"),  # 0.0733 vs 0.0710 from Table 32
}


def fail(msg):
    errors.append(msg)


def is_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def check_shape(doc):
    tables = doc.get("tables")
    if not isinstance(tables, list):
        fail("top-level 'tables' missing or not a list")
        return {}
    numbers = [t.get("number") for t in tables if isinstance(t, dict)]
    if numbers != list(range(1, 37)):
        missing = sorted(set(range(1, 37)) - set(numbers))
        dup = sorted({n for n in numbers if numbers.count(n) > 1})
        fail(f"table numbers are not 1..36 once each in order (missing {missing}, repeated {dup})")
    by_number = {}
    for t in tables:
        if not isinstance(t, dict):
            fail(f"table entry is not a mapping: {t!r}")
            continue
        n = t.get("number")
        by_number[n] = t
        where = f"Table {n}"
        for key in REQUIRED:
            if key not in t:
                fail(f"{where}: missing '{key}'")
        for key in t:
            if key not in REQUIRED and key not in OPTIONAL:
                fail(f"{where}: unknown key '{key}'")
        for key in ("title", "section", "setting", "unit"):
            if key in t and not isinstance(t[key], str):
                fail(f"{where}: '{key}' is not a string")
        if t.get("kind") not in ("result", "description"):
            fail(f"{where}: kind {t.get('kind')!r} not in {{result, description}}")
        elif (t["kind"] == "description") != (n in DESCRIPTIONS):
            fail(f"{where}: kind {t['kind']!r}, expected descriptions to be Tables {sorted(DESCRIPTIONS)}")
        if "row_header" in t and not (t["row_header"] is None or isinstance(t["row_header"], str)):
            fail(f"{where}: row_header is neither a string nor null")
        if "notes" in t and not isinstance(t["notes"], str):
            fail(f"{where}: notes is not a string")
        rows, cols, values = t.get("rows"), t.get("columns"), t.get("values")
        if not (isinstance(rows, list) and rows and all(isinstance(r, str) for r in rows)):
            fail(f"{where}: rows must be a non-empty list of strings")
            continue
        if not (isinstance(cols, list) and cols and all(isinstance(c, str) for c in cols)):
            fail(f"{where}: columns must be a non-empty list of strings")
            continue
        if not isinstance(values, list) or len(values) != len(rows):
            fail(f"{where}: values must have one list per row ({len(rows)} rows)")
            continue
        for label, row in zip(rows, values):
            if not isinstance(row, list) or len(row) != len(cols):
                fail(f"{where}, row {label!r}: {len(row) if isinstance(row, list) else row!r} entries, "
                     f"expected {len(cols)}")
                continue
            for cell in row:
                if not (cell is None or isinstance(cell, str) or is_number(cell)):
                    fail(f"{where}, row {label!r}: cell {cell!r} is not a number, string or null")
    return by_number


def check_figures(doc):
    figures = doc.get("figures", [])
    if not isinstance(figures, list):
        fail("'figures' is not a list")
        return
    for i, f in enumerate(figures):
        where = f"figures[{i}]"
        if not isinstance(f, dict):
            fail(f"{where}: not a mapping")
            continue
        for key in FIGURE_REQUIRED:
            if key not in f:
                fail(f"{where}: missing '{key}'")
        fig = f.get("figure")
        if not (fig is None or isinstance(fig, (int, str))):
            fail(f"{where}: figure must be an integer, a string or null")
        v = f.get("value")
        if not (v is None or isinstance(v, str) or is_number(v)):
            fail(f"{where}: value must be a number, a string or null")
        q = f.get("quote", "")
        if not isinstance(q, str) or not q or len(q.split()) >= 25:
            fail(f"{where}: quote must be a non-empty string under 25 words ({len(str(q).split())} words)")


def grid(t):
    return {r: dict(zip(t["columns"], row)) for r, row in zip(t["rows"], t["values"])}


def close(a, b, tol):
    return abs(a - b) <= tol + 1e-12


def check_consistency(tables):
    """Cross-table identities the dissertation's own numbers satisfy (to printed rounding)."""
    levels1 = ["RH1", "RV1", "RD1"]
    all9 = [f"R{d}{l}" for l in (1, 2, 3) for d in "HVD"]
    methods = [("Full Covariance", "Baseline Full Covariance Data"),
               ("Method 1", "Method 1 Data"), ("Method 2", "Method 2 Data")]

    def summary_vs_detail(summary_no, summary_row, detail_no, suffix, tol):
        s = grid(tables[summary_no])[summary_row]
        d = grid(tables[detail_no])
        for short, col in methods:
            for rows, lvl in ((levels1, "Level 1"), (all9, "Level 1-3")):
                mean = sum(d[r][col] for r in rows) / len(rows) / 100.0
                key = f"Additional Samples Using {short} / Average {lvl} Correlation Similarity{suffix}"
                printed = s[key]
                if not close(printed, mean, tol):
                    if (summary_no, summary_row, short, lvl) in KNOWN_MISMATCHES:
                        notes.append(f"Table {summary_no} [{summary_row}] [{short}, {lvl}] = {printed} "
                                     f"as printed; Table {detail_no} rows give {mean:.5f}")
                        continue
                    fail(f"Table {summary_no} [{summary_row}] [{short}, {lvl}] = {printed} but "
                         f"Table {detail_no} rows give {mean:.5f}")

    summary_vs_detail(6, "Data Generated with Exponential Correlating function", 26, "", 0.00005)
    summary_vs_detail(6, "Data Generated with Non-Exponential Correlating function", 28, "", 0.00005)
    for row, detail in (("Plant D, Light Wind", 30), ("Plant D, Medium Wind", 32),
                        ("Plant E, Light Wind", 34), ("Plant E, Medium Wind", 36)):
        summary_vs_detail(11, row, detail, " to Original Data", 0.00005)

    def matrix_vs(summary_no, summary_row, cols, detail_no):
        s = grid(tables[summary_no])[summary_row]
        d = tables[detail_no]["values"][0]
        dc = dict(zip(tables[detail_no]["columns"], d))
        for scol, dcol in zip(cols, ("Method 1 Data", "Method 2 Data")):
            if s[scol] != dc[dcol]:
                fail(f"Table {summary_no} [{summary_row}] [{scol}] = {s[scol]} but Table {detail_no} "
                     f"[{dcol}] = {dc[dcol]}")

    t7 = ["Additional Samples Using Method 1", "Additional Samples Using Method 2"]
    matrix_vs(7, "Original Data with Exponential Correlating function", t7, 25)
    matrix_vs(7, "Original Data with Non-Exponential Correlating function", t7, 27)
    t12 = tables[12]["columns"]
    for row, detail in (("Plant D, Light Wind", 29), ("Plant D, Medium Wind", 31),
                        ("Plant E, Light Wind", 33), ("Plant E, Medium Wind", 35)):
        matrix_vs(12, row, t12, detail)

    for row in grid(tables[4]).values():
        if not close(row["D"], row["H"] * row["V"], 0.002):
            fail(f"Table 4: D = {row['D']} is not about H*V = {row['H'] * row['V']:.4f}")


def main():
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("dissertation.yaml")
    with open(path, encoding="utf-8") as fh:
        doc = yaml.safe_load(fh)
    if not isinstance(doc, dict):
        print(f"{path}: not a YAML mapping")
        return 1
    tables = check_shape(doc)
    check_figures(doc)
    if not errors:
        check_consistency(tables)
    if errors:
        for e in errors:
            print("FAIL:", e)
        print(f"{path}: {len(errors)} problem(s)")
        return 1
    for n in notes:
        print("known printed mismatch:", n)
    n_cells = sum(len(t["rows"]) * len(t["columns"]) for t in tables.values())
    print(f"{path}: OK: {len(tables)} tables, {n_cells} cells, "
          f"{len(doc.get('figures', []))} figure statements; cross-table checks pass")
    return 0


if __name__ == "__main__":
    sys.exit(main())
