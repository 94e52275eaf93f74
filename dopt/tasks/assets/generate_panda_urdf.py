"""Regenerate panda.urdf next to this file from the DH table in dopt.tasks.panda.

Run ``python -m dopt.tasks.assets.generate_panda_urdf`` from the repository root after
changing the table; tests/dopt/tasks/test_panda.py fails while the shipped file is stale.
"""

from dopt.tasks.panda import PANDA_URDF, panda_urdf

if __name__ == "__main__":
    PANDA_URDF.write_text(panda_urdf())
