"""`python -m penumbra` and the `penumbra` console script: the command-line tool that comes with
the package (bin/penumbra beside this file), with the same arguments, output and exit codes."""

import os
import shutil
import sys


def _cli() -> str:
    bundled = os.path.join(os.path.dirname(os.path.abspath(__file__)), "bin", "penumbra")
    if os.access(bundled, os.X_OK):
        return bundled
    # A package installed by `cmake --install` has the CLI in PREFIX/bin instead.
    found = shutil.which("penumbra")
    if found and os.path.realpath(found) != os.path.realpath(sys.argv[0]):
        return found
    sys.exit("penumbra: error: the package has no command-line tool (bin/penumbra); "
             "reinstall it with pip install .")


def main() -> None:
    exe = _cli()
    os.execv(exe, [exe] + sys.argv[1:])


if __name__ == "__main__":
    main()
