"""Build the documentation site and photograph it in headless Chromium, offline.

Takes full-window screenshots of the front page, a user-guide page with formulas
(MathJax must render from the site itself), an API page and a gallery page, into
``docs/screenshots/``.  Chromium runs with every host name unresolvable, so a page
that needs the network shows it: raw ``$...$`` instead of typeset maths, a missing
figure or style sheet.

Chromium is Debian's (not a CI dependency)::

    sudo apt-get install --no-install-recommends chromium
    python docs/screenshots.py              # builds first; --no-build to reuse the build
"""

from __future__ import annotations

import argparse
import pathlib
import shutil
import subprocess
import sys
import tempfile

DOCS = pathlib.Path(__file__).resolve().parent
HTML = DOCS / "_build" / "html"
OUT = DOCS / "screenshots"

#: page (relative to the built site) -> screenshot name
PAGES = {
    "index.html": "front.png",
    "guide/classes.html": "guide_classes.png",
    "api/generated/phasemap.classify.html": "api_classify.png",
    "auto_examples/plot_solvability_maps.html": "gallery_solvability.png",
    "auto_examples/index.html": "gallery_index.png",
}


def chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    raise SystemExit("screenshots: no chromium on PATH "
                     "(sudo apt-get install --no-install-recommends chromium)")


def build() -> None:
    subprocess.run([sys.executable, "-m", "sphinx", "-W", "-q", "-b", "html", str(DOCS),
                    str(HTML)], check=True)


def shoot(browser: str, page: str, png: pathlib.Path, width: int, height: int) -> None:
    with tempfile.TemporaryDirectory() as profile:
        subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu",
                        "--hide-scrollbars", f"--user-data-dir={profile}",
                        "--host-resolver-rules=MAP * ~NOTFOUND",  # offline: no host resolves
                        "--virtual-time-budget=8000",  # let MathJax typeset
                        f"--window-size={width},{height}", f"--screenshot={png}",
                        (HTML / page).as_uri()],
                       check=True, capture_output=True, timeout=120)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--no-build", action="store_true", help="reuse docs/_build/html")
    parser.add_argument("--size", default="1400x1000", help="window WIDTHxHEIGHT (%(default)s)")
    args = parser.parse_args(argv)
    browser = chromium()
    if not args.no_build:
        build()
    width, height = (int(n) for n in args.size.split("x"))
    OUT.mkdir(exist_ok=True)
    for page, name in PAGES.items():
        if not (HTML / page).exists():
            raise SystemExit(f"screenshots: {page} is not in the build")
        shoot(browser, page, OUT / name, width, height)
        print(OUT / name)


if __name__ == "__main__":
    main()
