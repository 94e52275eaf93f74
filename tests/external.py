"""Where the papers' authors' own data lies: ``../shared/external`` beside the project
(described in its README; never part of the project). Tests that read it skip when it is
absent."""
from pathlib import Path

EXTERNAL = Path(__file__).resolve().parents[2] / "shared" / "external"
#: the state-vector-reduction authors' 100 clutter scenes, ``{0..99}.csv``
LAYOUTS = EXTERNAL / "ilqr_svr" / "push_mcl_layouts"
#: the key-particle authors' cloth and rope goals
AC_SOFTAGENT = EXTERNAL / "ac_softagent"
