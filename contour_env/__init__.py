"""contour_env: multi-axis CNC feed-drive contouring environments (SI units throughout).

Importing the package registers ``contour_env/Contouring-v0`` with Gymnasium. Made with no
case, plant or path (``gym.make("contour_env/Contouring-v0")``) it is the default case
:data:`DEFAULT_CASE`, the command line's default too.
"""

from gymnasium.envs.registration import register, registry

from .kernel_cache import install_locator, refresh_stale_caches

# before any kernel is compiled or loaded: the kernels cache in one folder per digest of their
# sources, shared by every checkout on this machine (contour_env.kernel_cache); numba's default
# in-tree folders, when the user chose theirs, lose caches made from other kernel sources
if not install_locator():
    refresh_stale_caches()

ENV_ID = "contour_env/Contouring-v0"
# the case of an env made without case, plant or path, and of the command line without --case
# (Lee 2012 case II); resolved in contour_env.cases.build_setup
DEFAULT_CASE = "hsm2-circle-II"

# the five-axis machine (Chen 2022) as an id of its own; Contouring-v0 with plant="five-axis"
# is the same env (contour_env.env.five_axis_family)
FIVE_AXIS_ENV_ID = "contour_env/FiveAxis-v0"

# id: (entry point, vector entry point), both in contour_env.env
ENTRY_POINTS = {
    ENV_ID: ("contouring_env:make_contouring_env", "vector_env:ContouringVectorEnv"),
    FIVE_AXIS_ENV_ID: ("five_axis_family:make_five_axis_env", "five_axis_family:FiveAxisVectorEnv"),
}
for _id, (_single, _vector) in ENTRY_POINTS.items():
    if _id not in registry:
        register(
            id=_id,
            entry_point=f"contour_env.env.{_single}",
            vector_entry_point=f"contour_env.env.{_vector}",
            disable_env_checker=False,
        )
del _id, _single, _vector

__version__ = "0.1.0"
__all__ = ["DEFAULT_CASE", "ENV_ID", "FIVE_AXIS_ENV_ID", "__version__"]
