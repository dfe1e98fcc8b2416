"""Check a file against the CF conventions offline: ``phasemap cfcheck FILE``.

``cfchecks`` (PyPI ``cfchecker``, which loads UDUNITS-2) downloads three
tables at every run: the standard names, the area types and the region
names.  A phasemap file uses none of their names, so local stand-ins (empty
tables, written to a temporary folder) let the check run on a machine
without network; any ``standard_name``, area type or region a file did use
would then be reported as an error, never passed silently.
"""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import tempfile

#: cfchecks option -> the XML of an empty table of that kind.
CF_TABLES = {
    "cf_standard_names": "<standard_name_table><version_number>0</version_number>"
                         "<last_modified>none</last_modified></standard_name_table>",
    "area_types": "<area_type_table><version_number>0</version_number>"
                  "<date>none</date></area_type_table>",
    "region_names": "<standard_region_list><version_number>0</version_number>"
                    "<date>none</date></standard_region_list>",
}


def cfcheck(path: str | os.PathLike, timeout: float = 300) -> tuple[str, bool]:
    """Run cfchecks on ``path`` offline; return ``(report, passed)``.

    ``passed`` means no errors and no warnings.  ValueError when the file is
    missing or cfchecks is not installed.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    exe = shutil.which("cfchecks")
    if exe is None:
        raise ValueError("cfchecks is not installed: pip install cfchecker (it needs "
                         "UDUNITS-2, Debian's libudunits2-0; bash .ci/system-deps installs both)")
    with tempfile.TemporaryDirectory(prefix="phasemap-cf-") as folder:
        tables = []
        for option, xml in CF_TABLES.items():
            table = pathlib.Path(folder) / f"{option}.xml"
            table.write_text(f'<?xml version="1.0"?>\n{xml}\n')
            tables += [f"--{option}", str(table)]
        run = subprocess.run([exe, "--version", "auto", *tables, str(path)],
                             capture_output=True, text=True, timeout=timeout)
    report = (run.stdout + run.stderr).strip()
    passed = (run.returncode == 0 and "ERRORS detected: 0" in report
              and "WARNINGS given: 0" in report)
    return report, passed
