"""Write the studies' claims tables into docs/guide/studies.md.

Runs every study in ``studies/`` in quick mode (as ``phasemap tour`` does, into a
temporary folder) and replaces the text between the ``claims:NAME`` markers of
the page with that study's claims table, the measured value beside the
paper's.  The page's count of claims and verdicts is checked against the claims
the studies give in the test session (``tests/test_study_overview.py``); the
tables themselves are as fresh as the last run of this script.

    python docs/claims.py          # about a minute and a half on warm caches
"""

from __future__ import annotations

import contextlib
import io
import pathlib
import re
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "guide" / "studies.md"
BLOCK = re.compile(r"(<!-- claims:(\w+) -->\n)(.*?)(<!-- /claims -->)", re.S)


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def table(claims) -> str:
    """One study's claims as a Markdown table (claim, paper, measured, verdict)."""
    rows = ["| claim | paper | measured | verdict |", "|---|---|---|---|"]
    rows += [f"| {_cell(c.claim)} | {_cell(c.paper)} | {_cell(c.measured)} | {c.verdict} |"
             for c in claims]
    return "\n".join(rows) + "\n"


def parse(text: str) -> dict[str, list[tuple[str, str, str, str]]]:
    """The page's tables: {study: [(claim, paper, measured, verdict), ...]}."""
    out = {}
    for match in BLOCK.finditer(text):
        rows = [line for line in match.group(3).splitlines() if line.startswith("| ")][1:]
        cells = [re.split(r"(?<!\\)\|", row.strip())[1:-1] for row in rows]
        out[match.group(2)] = [tuple(c.strip().replace("\\|", "|") for c in row)
                               for row in cells]
    return out


def main() -> int:
    sys.path.insert(0, str(ROOT))
    from phasemap.tour import ORDER, load

    text = PAGE.read_text()
    with tempfile.TemporaryDirectory() as out:
        for name in ORDER:
            print(f"running studies/{name}.py --quick", flush=True)
            with contextlib.redirect_stdout(io.StringIO()):
                claims = load(ROOT / "studies" / f"{name}.py").main(["--quick", "--out", out])
            marker = f"<!-- claims:{name} -->\n"
            if marker not in text:
                raise SystemExit(f"{PAGE}: no marker {marker.strip()} for study {name}")
            text = BLOCK.sub(lambda m: m.group(1) + table(claims) + m.group(4)
                             if m.group(2) == name else m.group(0), text)
    PAGE.write_text(text)
    print(f"wrote the claims tables into {PAGE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
