"""The studies' claims tables on docs/guide/studies.md.

Runs every study in ``studies/`` in quick mode (as ``phasemap tour`` does, into a
temporary folder) and puts each study's claims table, the measured value beside
the paper's, between the page's ``claims:NAME`` markers.  The documentation build
does this on the page it renders (``docs/conf.py``: the tables are made by the
build that shows them, so they cannot go stale; the page in the repository keeps
its markers empty); run as a script it writes the tables into the page itself.
The page's count of claims and verdicts is checked against the claims the studies
give in the test session (``tests/test_study_overview.py``).

    python docs/claims.py          # about a minute and a half on warm caches

In CI the test session has just run every study in quick mode (tests/conftest.py's
``studies`` fixture): with ``PHASEMAP_STUDY_CLAIMS`` set, it keeps their claims and
this build reads them (:func:`from_tests`) instead of running the studies again.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
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


def from_tests(name: str):
    """The claims the test session's run of study ``name`` gave, where
    ``PHASEMAP_STUDY_CLAIMS`` names the folder it kept them in (tests/conftest.py; .ci/run
    sets it for the tests and this build, which run on the same tree one after the
    other); None where it is unset or holds no file for the study."""
    folder = os.environ.get("PHASEMAP_STUDY_CLAIMS")
    path = pathlib.Path(folder) / f"{name}.json" if folder else None
    if path is None or not path.is_file():
        return None
    from phasemap.study import Claim

    return [Claim(*row) for row in json.loads(path.read_text())]


def filled(text: str) -> str:
    """``text`` (the page) with each study's claims table between its markers."""
    sys.path.insert(0, str(ROOT))
    from phasemap.tour import ORDER, load

    with tempfile.TemporaryDirectory() as out:
        for name in ORDER:
            claims = from_tests(name)
            if claims is None:
                print(f"running studies/{name}.py --quick", flush=True)
                with contextlib.redirect_stdout(io.StringIO()):
                    claims = load(ROOT / "studies" / f"{name}.py").main(["--quick", "--out",
                                                                         out])
            else:
                print(f"studies/{name}.py: its claims from the test session", flush=True)
            marker = f"<!-- claims:{name} -->\n"
            if marker not in text:
                raise SystemExit(f"{PAGE}: no marker {marker.strip()} for study {name}")
            text = BLOCK.sub(lambda m: m.group(1) + table(claims) + m.group(4)
                             if m.group(2) == name else m.group(0), text)
    return text


def main() -> int:
    PAGE.write_text(filled(PAGE.read_text()))
    print(f"wrote the claims tables into {PAGE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
