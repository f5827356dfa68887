"""libtrioct through ctypes: the shared library found and loaded, and trioct.h's structs and
functions declared field for field.

The declarations mirror client/trioct.h exactly (python/tests/test_trioct.py compiles a C
program against the header and compares every size and offset with these), so a struct
the library fills is read here as the library wrote it. Only what the package calls is
declared.
"""

import ctypes
import os

from . import _constants

# ---- finding the library -------------------------------------------------------------------

# The soname this package was written against: a library of another major version has
# another ABI, so no other name is ever tried (ctypes.util.find_library would happily
# return a libtrioct.so.4).
SONAME = "libtrioct.so.4"


def _candidates():
    """Where the library may be, best first: $TRIOCT_LIBRARY, then the one the build wrote
    beside this package (_paths.py: relative to this directory, so that a DESTDIR staging
    tree or a moved prefix finds its own copy, then the absolute path), then the soname for
    the dynamic loader to search (LD_LIBRARY_PATH, ldconfig's cache)."""
    env = os.environ.get("TRIOCT_LIBRARY")
    if env:
        return [env]
    out = []
    try:
        from . import _paths
    except ImportError:  # the sources themselves, not a build or install of them
        _paths = None
    if _paths is not None:
        here = os.path.dirname(os.path.abspath(__file__))
        for path in (os.path.normpath(os.path.join(here, _paths.LIBRARY_RELATIVE)), _paths.LIBRARY):
            if path not in out and os.path.exists(path):
                out.append(path)
    out.append(SONAME)
    return out


def _load():
    errors = []
    for path in _candidates():
        try:
            return ctypes.CDLL(path), path
        except OSError as e:
            errors.append("%s: %s" % (path, e))
    raise ImportError("trioct: cannot load libtrioct (set TRIOCT_LIBRARY to its path): " + "; ".join(errors))


lib, _requested = _load()


class _DlInfo(ctypes.Structure):
    _fields_ = [("dli_fname", ctypes.c_char_p), ("dli_fbase", ctypes.c_void_p),
                ("dli_sname", ctypes.c_char_p), ("dli_saddr", ctypes.c_void_p)]


def _loaded_path():
    """The file the dynamic loader really mapped (dladdr of one of its functions): a bare
    soname says nothing about which copy was found."""
    try:
        libc = ctypes.CDLL(None)
        dladdr = libc.dladdr
        dladdr.argtypes = [ctypes.c_void_p, ctypes.POINTER(_DlInfo)]
        dladdr.restype = ctypes.c_int
        info = _DlInfo()
        addr = ctypes.cast(lib.trioct_connect, ctypes.c_void_p).value
        if dladdr(addr, ctypes.byref(info)) and info.dli_fname:
            return os.fsdecode(info.dli_fname)
    except (OSError, AttributeError):
        pass
    return _requested


path = _loaded_path()

# ---- the caps and names of trioct_limits.h (the values the header was built with) -------------

MAX_NAME_LEN = _constants.LIMITS["TRIOCT_MAX_NAME_LEN"]
MAX_MESSAGE_LEN = _constants.LIMITS["TRIOCT_MAX_MESSAGE_LEN"]
MAX_PATH_LEN = _constants.LIMITS["TRIOCT_MAX_PATH_LEN"]
MAX_SHAPES = _constants.LIMITS["TRIOCT_MAX_SHAPES"]
MAX_RAYS = _constants.LIMITS["TRIOCT_MAX_RAYS"]
MAX_POSES = _constants.LIMITS["TRIOCT_MAX_POSES"]
MAX_POINTS = _constants.LIMITS["TRIOCT_MAX_POINTS"]
MAX_INLINE_SHAPE_TRIANGLES = _constants.LIMITS["TRIOCT_MAX_INLINE_SHAPE_TRIANGLES"]

# ---- enums ---------------------------------------------------------------------------------------

ACCURACY_WORLD, ACCURACY_EXACT, ACCURACY_SEED, ACCURACY_FAST = -1, 0, 1, 2
EFFECT_RAYS, EFFECT_TRIANGLES, EFFECT_MESHES, EFFECT_DISTANCE = 1, 2, 4, 8
RAY_ANY, RAY_CLOSEST, RAY_ALL = 0, 1, 2
CONTACT_CROSSING, CONTACT_TOUCH = 0, 1
MESH_YESNO, MESH_PAIRS = 0, 1

# ---- structs -------------------------------------------------------------------------------------
# Each carries _c_name_, the C type it mirrors, for the layout test.

c_int, c_int32, c_int64, c_double, c_size_t = ctypes.c_int, ctypes.c_int32, ctypes.c_int64, ctypes.c_double, ctypes.c_size_t
c_char_p, c_void_p, c_uint8, c_uint64 = ctypes.c_char_p, ctypes.c_void_p, ctypes.c_uint8, ctypes.c_uint64
NameBuf = ctypes.c_char * (MAX_NAME_LEN + 1)


class Vec3(ctypes.Structure):
    _c_name_ = "trioct_vec3"
    _fields_ = [("x", c_double), ("y", c_double), ("z", c_double)]


class Triangle(ctypes.Structure):
    _c_name_ = "trioct_triangle"
    _fields_ = [("a", Vec3), ("b", Vec3), ("c", Vec3)]


class Pose(ctypes.Structure):
    _c_name_ = "trioct_pose"
    _fields_ = [("r", c_double * 9), ("t", Vec3)]


class ConnectOptions(ctypes.Structure):
    _c_name_ = "trioct_connect_options"
    _fields_ = [("url", c_char_p), ("prefix", c_char_p), ("lcm", c_void_p), ("queue_capacity", c_int),
                ("send_deadlines", c_int), ("admin_key_file", c_char_p), ("no_retries", c_int)]


class Reply(ctypes.Structure):
    _c_name_ = "trioct_reply"
    _fields_ = [("status", c_int), ("message", ctypes.c_char * (MAX_MESSAGE_LEN + 1)), ("daemon", NameBuf),
                ("world", NameBuf), ("world_version", c_int64), ("request_id", c_int64), ("chunks", c_int)]


class ObjectNames(ctypes.Structure):
    _c_name_ = "trioct_object_names"
    _fields_ = [("count", c_size_t), ("names", ctypes.POINTER(NameBuf))]


class RayQuery(ctypes.Structure):
    _c_name_ = "trioct_ray_query"
    # origins and directions as plain addresses: they point into numpy arrays.
    _fields_ = [("world", c_char_p), ("detail", c_int), ("accuracy", c_int), ("tmin", c_double),
                ("tmax", c_double), ("max_hits", c_int), ("count", c_size_t), ("origins", c_void_p),
                ("directions", c_void_p)]


class RayHit(ctypes.Structure):
    _c_name_ = "trioct_ray_hit"
    _fields_ = [("ray", c_int32), ("t", c_double), ("object", c_int32), ("triangle", c_int32), ("u", c_double),
                ("v", c_double), ("normal", Vec3)]


class RayResult(ctypes.Structure):
    _c_name_ = "trioct_ray_result"
    _fields_ = [("reply", Reply), ("detail", c_int), ("num_rays", c_size_t), ("found", ctypes.POINTER(c_int32)),
                ("num_hits", c_size_t), ("hits", ctypes.POINTER(RayHit)), ("objects", ObjectNames)]


class MeshQuery(ctypes.Structure):
    _c_name_ = "trioct_mesh_query"
    _fields_ = [("world", c_char_p), ("detail", c_int), ("accuracy", c_int), ("shape", c_char_p),
                ("num_shape_triangles", c_size_t), ("shape_triangles", c_void_p), ("num_poses", c_size_t),
                ("poses", c_void_p)]


class MeshPair(ctypes.Structure):
    _c_name_ = "trioct_mesh_pair"
    _fields_ = [("pose", c_int32), ("shape_triangle", c_int32), ("object", c_int32), ("world_triangle", c_int32)]


class MeshResult(ctypes.Structure):
    _c_name_ = "trioct_mesh_result"
    _fields_ = [("reply", Reply), ("detail", c_int), ("num_poses", c_size_t), ("found", ctypes.POINTER(c_int32)),
                ("num_pairs", c_size_t), ("pairs", ctypes.POINTER(MeshPair)), ("objects", ObjectNames)]


class PointDistanceQuery(ctypes.Structure):
    _c_name_ = "trioct_point_distance_query"
    _fields_ = [("world", c_char_p), ("within", c_double), ("count", c_size_t), ("points", c_void_p)]


class ShapeDistanceQuery(ctypes.Structure):
    _c_name_ = "trioct_shape_distance_query"
    _fields_ = [("world", c_char_p), ("within", c_double), ("shape", c_char_p), ("num_shape_triangles", c_size_t),
                ("shape_triangles", c_void_p), ("num_poses", c_size_t), ("poses", c_void_p)]


class Distance(ctypes.Structure):
    _c_name_ = "trioct_distance"
    _fields_ = [("item", c_int32), ("found", c_int), ("clear", c_int), ("distance", c_double),
                ("bound", c_double), ("lower", c_double), ("upper", c_double), ("point", Vec3),
                ("shape_point", Vec3), ("object", c_int32), ("triangle", c_int32), ("shape_triangle", c_int32),
                ("feature", c_int), ("feature_index", c_int), ("inside", c_int)]


class DistanceResult(ctypes.Structure):
    _c_name_ = "trioct_distance_result"
    _fields_ = [("reply", Reply), ("num_results", c_size_t), ("results", ctypes.POINTER(Distance)),
                ("objects", ObjectNames)]


class WorldInfo(ctypes.Structure):
    _c_name_ = "trioct_world_info"
    _fields_ = [
        ("name", NameBuf), ("daemon", NameBuf), ("version", c_int64),
        ("source", ctypes.c_char * (MAX_PATH_LEN + 1)), ("accuracy", ctypes.c_char * 16),
        ("seed_epsilon", c_double), ("effects", c_int),
        ("triangles", c_int64), ("vertices", c_int64), ("degenerate", c_int64), ("duplicates", c_int64),
        ("bbox_min", Vec3), ("bbox_max", Vec3),
        ("nodes", c_int64), ("leaves", c_int64), ("max_level", c_int), ("resolution", c_double),
        ("world_size", c_double), ("world_min", Vec3),
        ("bytes_nodes", c_int64), ("bytes_leaf_lists", c_int64), ("bytes_triangles", c_int64),
        ("bytes_effects", c_int64), ("bytes_total", c_int64),
        ("memory_bytes", c_int64), ("memory_budget", c_int64), ("build_seconds", c_double),
        ("load_seconds", c_double), ("objects", c_int64), ("queries", c_int64),
        ("last_error", ctypes.c_char * (MAX_MESSAGE_LEN + 1)),
        ("num_shapes", c_int), ("shapes", NameBuf * MAX_SHAPES),
    ]


class AdminResult(ctypes.Structure):
    _c_name_ = "trioct_admin_result"
    _fields_ = [("reply", Reply), ("num_worlds", c_size_t), ("worlds", ctypes.POINTER(WorldInfo))]


class LoadOptions(ctypes.Structure):
    _c_name_ = "trioct_load_options"
    _fields_ = [("world", c_char_p), ("daemon", c_char_p), ("mesh_path", c_char_p), ("resolution", c_double),
                ("accuracy", c_int), ("seed_epsilon", c_double), ("effects", c_int)]


class ListOptions(ctypes.Structure):
    _c_name_ = "trioct_list_options"
    _fields_ = [("gather_ms", c_int), ("expect_daemons", c_int)]


class ListResult(ctypes.Structure):
    _c_name_ = "trioct_list_result"
    _fields_ = [("reply", Reply), ("num_daemons", c_size_t), ("daemons", ctypes.POINTER(Reply)),
                ("num_worlds", c_size_t), ("worlds", ctypes.POINTER(WorldInfo))]


class LoadProgress(ctypes.Structure):
    _c_name_ = "trioct_load_progress"
    _fields_ = [("world", NameBuf), ("client_id", c_int64), ("request_id", c_int64), ("phase", ctypes.c_char * 32),
                ("files_done", c_int), ("files_total", c_int), ("triangles", c_int64), ("elapsed_seconds", c_double)]


class DaemonStatus(ctypes.Structure):
    _c_name_ = "trioct_daemon_status"
    _fields_ = [
        ("reply", Reply), ("utime", c_int64), ("version", ctypes.c_char * 64), ("uptime_us", c_int64),
        ("state", c_int), ("threads", c_int), ("queue_depth", c_int), ("queue_capacity", c_int),
        ("memory_used", c_int64), ("memory_budget", c_int64), ("served", c_int64 * 7), ("malformed", c_int64),
        ("duplicates_answered", c_int64), ("duplicates_joined", c_int64),
        ("num_status_codes", c_size_t), ("replies_by_status", ctypes.POINTER(c_int64)),
        ("latency_p50_us", c_int64), ("latency_p99_us", c_int64), ("latency_count", c_int64),
        ("num_worlds", c_size_t), ("worlds", ctypes.POINTER(WorldInfo)),
        ("num_loads", c_size_t), ("loads", ctypes.POINTER(LoadProgress)),
    ]


STRUCTS = (Vec3, Triangle, Pose, ConnectOptions, Reply, ObjectNames, RayQuery, RayHit, RayResult, MeshQuery,
           MeshPair, MeshResult, PointDistanceQuery, Distance, DistanceResult, WorldInfo, AdminResult, LoadOptions, ListOptions, ListResult, LoadProgress,
           DaemonStatus)

# ---- functions -----------------------------------------------------------------------------------


def _declare(name, restype, *argtypes):
    f = getattr(lib, name)
    f.restype = restype
    f.argtypes = list(argtypes)
    return f


P = ctypes.POINTER
trioct_connect = _declare("trioct_connect", c_void_p, P(ConnectOptions), P(c_int), ctypes.c_char_p, c_size_t)
trioct_disconnect = _declare("trioct_disconnect", None, c_void_p)
trioct_url = _declare("trioct_url", c_char_p, c_void_p)
trioct_prefix = _declare("trioct_prefix", c_char_p, c_void_p)
trioct_client_id = _declare("trioct_client_id", c_uint64, c_void_p)
trioct_reply_channel = _declare("trioct_reply_channel", c_char_p, c_void_p)
trioct_ray_query_default = _declare("trioct_ray_query_default", RayQuery, c_char_p)
trioct_rays_contact = _declare("trioct_rays_contact", c_int, c_void_p, P(RayQuery), c_int, c_int, P(RayResult))
trioct_ray_result_free = _declare("trioct_ray_result_free", None, P(RayResult))
trioct_mesh = _declare("trioct_mesh", c_int, c_void_p, P(MeshQuery), c_int, P(MeshResult))
trioct_mesh_result_free = _declare("trioct_mesh_result_free", None, P(MeshResult))
trioct_point_distance = _declare("trioct_point_distance", c_int, c_void_p, P(PointDistanceQuery), c_int,
                                 P(DistanceResult))
trioct_shape_distance = _declare("trioct_shape_distance", c_int, c_void_p, P(ShapeDistanceQuery), c_int,
                                 P(DistanceResult))
trioct_clearance = _declare("trioct_clearance", c_int, c_void_p, P(ShapeDistanceQuery), c_int, P(DistanceResult))
trioct_distance_result_free = _declare("trioct_distance_result_free", None, P(DistanceResult))
trioct_pose_from_quaternion = _declare("trioct_pose_from_quaternion", c_int, c_double, c_double, c_double,
                                       c_double, c_double, c_double, c_double, P(Pose))
trioct_info = _declare("trioct_info", c_int, c_void_p, c_char_p, c_int, P(AdminResult))
trioct_load = _declare("trioct_load", c_int, c_void_p, P(LoadOptions), c_int, P(AdminResult))
trioct_unload = _declare("trioct_unload", c_int, c_void_p, c_char_p, c_int, P(AdminResult))
trioct_admin_result_free = _declare("trioct_admin_result_free", None, P(AdminResult))
trioct_list = _declare("trioct_list", c_int, c_void_p, P(ListOptions), c_int, P(ListResult))
trioct_list_result_free = _declare("trioct_list_result_free", None, P(ListResult))
trioct_next_status = _declare("trioct_next_status", c_int, c_void_p, c_char_p, c_int, P(DaemonStatus))
trioct_daemon_status_free = _declare("trioct_daemon_status_free", None, P(DaemonStatus))
