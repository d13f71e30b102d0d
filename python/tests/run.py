#!/usr/bin/env python3
"""Run the Python package's pytest suite as one meson test (tests/meson.build).

The package is built and installed into a venv by `sh tools/quickstart.sh
test` (EPSNET_VENV, default build-venv at the checkout's root). Each pytest
case is printed as "ok   NAME" or "FAIL NAME", the lines .ci/run counts;
skipped cases as "skip NAME". Exit status 77 (meson's skip) when the venv or
the package is not there.
"""
import os
import pathlib
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

here = pathlib.Path(__file__).resolve().parent
root = here.parents[1]
venv = pathlib.Path(os.environ.get("EPSNET_VENV") or root / "build-venv")
python = venv / "bin" / "python"
if not python.exists() or subprocess.run([python, "-c", "import epsnet._epsnet"], cwd=tempfile.gettempdir(),
                                          capture_output=True).returncode != 0:
    print(f"skip: no venv with the epsnet package at {venv} (sh tools/quickstart.sh test makes it)")
    sys.exit(77)

with tempfile.TemporaryDirectory() as tmp:
    report = pathlib.Path(tmp) / "junit.xml"
    # note: run from a folder without an epsnet/ in it, so that the installed
    # package is the one imported
    rc = subprocess.run([python, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--junitxml={report}",
                         f"--basetemp={tmp}/t", str(here)], cwd=tmp).returncode
    cases = ET.parse(report).getroot().iter("testcase") if report.exists() else []
    for case in cases:
        name = f"{case.get('classname', '').rsplit('.', 1)[-1]}::{case.get('name')}"
        if case.find("failure") is not None or case.find("error") is not None:
            print(f"FAIL {name}")
        elif case.find("skipped") is not None:
            print(f"skip {name}")
        else:
            print(f"ok   {name}")
sys.exit(rc)
