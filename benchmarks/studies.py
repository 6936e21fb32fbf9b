"""First-run benchmark of every study (same as ``bipedlab bench --studies``): each study's short
version from an empty compilation cache, then warm; compile and run seconds, compiled
programs, peak resident memory.

    python benchmarks/studies.py [NAME ...] [--json] [--cold-only] [--timeout S]

NAME (quoted when it has several words) selects studies by their leading words (``walk``,
``"walk mabel"``); by default every study
but the long ones (``experiment mabel sweep``) runs.
"""
import sys

from bipedlab.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "--studies", *sys.argv[1:]]))
