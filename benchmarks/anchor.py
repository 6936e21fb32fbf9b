"""The anchor scenario's speed beside MuJoCo (same as ``bipedlab bench``).

    python benchmarks/anchor.py [--json] [--batch 64 256 1024] [--no-mujoco]

Run on a GPU machine with ``--no-mujoco --batch 1024 8192 65536`` for the large batches.
"""
import sys

from bipedlab.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
