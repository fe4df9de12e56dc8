"""Runs `fmpy validate` (fmpy.cli) on each FMU; prints one JSON object {fmu: [output, exit code]}."""
import contextlib
import io
import json
import sys

from fmpy.cli import main

result = {}
for fmu in sys.argv[1:]:
    out = io.StringIO()
    code = 0
    sys.argv = ['fmpy', 'validate', fmu]
    with contextlib.redirect_stdout(out):
        try:
            main()
        except SystemExit as e:
            code = e.code or 0
    result[fmu] = [out.getvalue(), code]
print(json.dumps(result))
