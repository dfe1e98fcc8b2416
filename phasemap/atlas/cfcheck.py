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

from phasemap.core import args as _args

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

    ``passed`` means no errors and no warnings.  ValueError, in one line, when
    the file is missing or not netCDF, when cfchecks is not installed, or when
    cfchecks itself fails (its traceback's last line).
    """
    path = _args.existing_file("path", path, "cfcheck")
    try:
        netcdf = is_netcdf(path)
    except OSError as err:
        raise ValueError(f"{path}: {err.strerror or err}") from None
    if not netcdf:
        raise ValueError(f"{path}: not a netCDF file (neither netCDF classic nor netCDF-4/HDF5 "
                         "by its first bytes); cfchecks checks netCDF files")
    exe = shutil.which("cfchecks")
    if exe is None:
        raise ValueError("cfchecks is not installed: pip install \"phasemap[cf]\" (from a "
                         "clone: pip install \".[cf]\"; it needs "
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
    if "Traceback (most recent call last)" in report:  # cfchecks itself failed: say why
        raise ValueError(f"{path}: cfchecks failed: {report.splitlines()[-1].strip()}")
    passed = (run.returncode == 0 and "ERRORS detected: 0" in report
              and "WARNINGS given: 0" in report)
    return report, passed


#: The first bytes of a netCDF file: classic, 64-bit offset, 64-bit data (CDF-5), and
#: netCDF-4 (an HDF5 signature, at 0 or after a user block of 512 * 2**k bytes).
NETCDF_MAGIC = (b"CDF\x01", b"CDF\x02", b"CDF\x05")
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"


def is_netcdf(path: str | os.PathLike) -> bool:
    """Whether ``path`` starts as a netCDF file does (classic, CDF-5 or netCDF-4/HDF5)."""
    with open(path, "rb") as fh:
        if fh.read(4) in NETCDF_MAGIC:
            return True
        offset = 0
        while True:
            fh.seek(offset)
            head = fh.read(len(HDF5_MAGIC))
            if head == HDF5_MAGIC:
                return True
            if len(head) < len(HDF5_MAGIC):
                return False
            offset = 512 if offset == 0 else 2 * offset
