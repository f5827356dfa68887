"""The connection and its calls: numpy arrays in, numpy arrays out.

Each call builds the C query over the arrays' own memory (float64, C order: an (N, 3) array
is N trioct_vec3 back to back), calls the synchronous libtrioct function, copies what it
needs out of the C result and frees it before returning, so no Python object ever points
into memory the library owns. Batches longer than one request may carry are cut into
requests under the cap and their answers joined, as the trioct command does: a caller never
meets TRIOCT_MAX_RAYS or TRIOCT_MAX_POSES.
"""

import ctypes
import math
import threading
import types

import numpy as np

from . import _lib
from .errors import Status, TransportError, error_for

_ACCURACY = {None: _lib.ACCURACY_WORLD, "world": _lib.ACCURACY_WORLD, "exact": _lib.ACCURACY_EXACT,
             "seed": _lib.ACCURACY_SEED, "fast": _lib.ACCURACY_FAST}
_EFFECTS = {"rays": _lib.EFFECT_RAYS, "triangles": _lib.EFFECT_TRIANGLES, "meshes": _lib.EFFECT_MESHES,
            "distance": _lib.EFFECT_DISTANCE}
_DAEMON_STATES = ("starting", "ready", "reloading", "stopping")
_SERVED = ("ray", "triangle", "mesh", "admin", "objects", "state", "distance")


# ---- arguments -----------------------------------------------------------------------------------


def _text(value, what, optional=False):
    """A str argument as the bytes C reads; None stays NULL where the C call allows it."""
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise TypeError("%s must be a str, not %s" % (what, type(value).__name__))
    if "\0" in value:
        raise ValueError("%s contains a NUL character" % what)
    return value.encode()


def _accuracy(value):
    if isinstance(value, str):
        value = value.lower()
    if value in _ACCURACY:
        return _ACCURACY[value]
    raise ValueError("accuracy %r: expected None, 'world', 'exact', 'seed' or 'fast'" % (value,))


def _timeout(value, default):
    if value is None:
        return default
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError("timeout_ms must be an int (milliseconds; < 0: no limit)")
    return max(min(int(value), 2**31 - 1), -1)


def _numbers(value, what):
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError("%s: not an array of numbers (%s)" % (what, e)) from None


def _points(value, what):
    """An (N, 3) array, or (3,) for one point; returns (array, shared)."""
    a = _numbers(value, what)
    if a.shape == (3,):
        return a.reshape(1, 3), True
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError("%s has shape %s; expected (N, 3), or (3,) for one shared by every ray"
                         % (what, a.shape))
    return a, False


def _ray_arrays(origins, dirs):
    o, o_shared = _points(origins, "origins")
    d, d_shared = _points(dirs, "dirs")
    if o_shared and not d_shared:
        o = np.broadcast_to(o, d.shape)
    elif d_shared and not o_shared:
        d = np.broadcast_to(d, o.shape)
    elif o.shape[0] != d.shape[0]:
        raise ValueError("origins has %d rays and dirs %d; give as many of each, or one origin or "
                         "direction of shape (3,) for all" % (o.shape[0], d.shape[0]))
    # The C query reads N trioct_vec3 back to back: contiguous float64, copied only when needed.
    return np.ascontiguousarray(o, dtype=np.float64), np.ascontiguousarray(d, dtype=np.float64)


def _poses(value):
    """Poses as an (N, 12) array of trioct_pose (row-major R, then t). Accepted: (N, 3)
    translations, (N, 7) x y z qw qx qy qz, (N, 3, 4) or (N, 4, 4) matrices [R | t], and
    one pose of any of these forms without the leading N."""
    a = _numbers(value, "poses")
    if a.ndim == 1 and a.shape[0] in (3, 7):
        a = a.reshape(1, -1)
    elif a.ndim == 2 and a.shape in ((3, 4), (4, 4)):
        a = a.reshape(1, *a.shape)
    n = a.shape[0] if a.ndim >= 1 else 0
    out = np.zeros((n, 12), dtype=np.float64)
    if a.ndim == 2 and a.shape[1] == 3:
        out[:, [0, 4, 8]] = 1.0
        out[:, 9:] = a
    elif a.ndim == 2 and a.shape[1] == 7:
        # The library's conversion, so the matrix is the one the daemon itself would make
        # from these numbers (normalised; a length off by more than 1e-3 is ERR_BAD_POSE).
        pose = _lib.Pose()
        for i, (x, y, z, qw, qx, qy, qz) in enumerate(a):
            rc = _lib.trioct_pose_from_quaternion(x, y, z, qw, qx, qy, qz, ctypes.byref(pose))
            if rc != Status.OK:
                raise error_for(rc, "pose %d (%g %g %g, quaternion %g %g %g %g): %s"
                                % (i, x, y, z, qw, qx, qy, qz, error_for(rc).message))
            out[i, :9] = pose.r
            out[i, 9:] = (pose.t.x, pose.t.y, pose.t.z)
    elif a.ndim == 3 and a.shape[1:] in ((3, 4), (4, 4)):
        if a.shape[1] == 4:
            bad = np.nonzero(np.any(a[:, 3, :] != (0.0, 0.0, 0.0, 1.0), axis=1))[0]
            if bad.size:
                raise ValueError("pose %d: a 4 x 4 pose's last row must be 0 0 0 1, not %s"
                                 % (bad[0], a[bad[0], 3, :]))
        out[:, :9] = a[:, :3, :3].reshape(n, 9)
        out[:, 9:] = a[:, :3, 3]
    else:
        raise ValueError("poses has shape %s; expected (N, 3) translations, (N, 7) x y z qw qx qy qz, "
                         "or (N, 3, 4) / (N, 4, 4) matrices" % (a.shape,))
    return out


def _triangles(value):
    a = _numbers(value, "shape")
    if a.shape == (3, 3):
        a = a.reshape(1, 3, 3)
    if a.ndim != 3 or a.shape[1:] != (3, 3):
        raise ValueError("shape has shape %s; expected a shape name, or (M, 3, 3) triangles (three "
                         "vertices of x y z each)" % (a.shape,))
    return np.ascontiguousarray(a)


def _effects(value):
    if value is None:
        return 0
    if isinstance(value, str):
        value = value.replace(",", " ").split()
    bits = 0
    for e in value:
        if e not in _EFFECTS:
            raise ValueError("effect %r: expected 'rays', 'triangles' or 'meshes'" % (e,))
        bits |= _EFFECTS[e]
    return bits


# ---- results -------------------------------------------------------------------------------------


def _str(raw):
    """A char array field, which ctypes reads as the bytes before its NUL."""
    return raw.decode("utf-8", "replace")


def _vec(v):
    return (v.x, v.y, v.z)


def _failure(reply, part=None):
    message = _str(reply.message)
    if part:
        message = "%s: %s" % (part, message)
    return error_for(reply.status, message, _str(reply.daemon), _str(reply.world))


def _dtype(ctype):
    """The numpy dtype of a ctypes type, with the struct's own offsets and size (numpy's
    reading of ctypes' buffer format guesses at nested structs)."""
    if issubclass(ctype, ctypes.Structure):
        names = [f[0] for f in ctype._fields_]
        return np.dtype({"names": names, "formats": [_dtype(f[1]) for f in ctype._fields_],
                         "offsets": [getattr(ctype, n).offset for n in names], "itemsize": ctypes.sizeof(ctype)})
    return np.dtype(ctype)


def _records(pointer, count, ctype):
    """count records of ctype at pointer, copied into a numpy array the library cannot free."""
    if count == 0 or not pointer:
        return np.zeros(0, dtype=_dtype(ctype))
    size = ctypes.sizeof(ctype) * count
    return np.frombuffer(ctypes.string_at(pointer, size), dtype=_dtype(ctype), count=count)


class WorldInfo(types.SimpleNamespace):
    """One world as its daemon describes it: every field of trioct_world_info (names as
    there; boxes as (x, y, z) tuples; effects a frozenset of 'rays', 'triangles', 'meshes';
    shapes the list of its query shapes)."""

    def __repr__(self):
        return "WorldInfo(name=%r, daemon=%r, version=%d, triangles=%d, effects=%s)" % (
            self.name, self.daemon, self.version, self.triangles, sorted(self.effects))


def _world(w):
    d = {}
    for name, ctype in w._fields_:
        value = getattr(w, name)
        if name == "shapes":
            value = [v.value.decode("utf-8", "replace") for v in value[:w.num_shapes]]
        elif name == "effects":
            value = frozenset(n for n, bit in _EFFECTS.items() if value & bit)
        elif ctype is _lib.Vec3:
            value = _vec(value)
        elif isinstance(value, bytes):  # c_char arrays read as bytes up to their NUL
            value = value.decode("utf-8", "replace")
        d[name] = value
    return WorldInfo(**d)


class DaemonStatus(types.SimpleNamespace):
    """A daemon's heartbeat: the fields of trioct_daemon_status, with .daemon its name,
    .state one of 'starting', 'ready', 'reloading', 'stopping', .served and
    .replies_by_status dicts, .worlds a list of WorldInfo and .loads the world builds under
    way (dicts: world, client_id, request_id, phase, files_done, files_total, triangles,
    elapsed_seconds)."""

    def __repr__(self):
        return "DaemonStatus(daemon=%r, state=%r, version=%r, worlds=%d)" % (
            self.daemon, self.state, self.version, len(self.worlds))


def _daemon_status(s):
    replies = {}
    for code in range(s.num_status_codes):
        try:
            key = Status(code)
        except ValueError:
            key = code
        replies[key] = s.replies_by_status[code]
    return DaemonStatus(
        daemon=_str(s.reply.daemon), utime=s.utime, version=s.version.decode("utf-8", "replace"),
        uptime_us=s.uptime_us,
        state=_DAEMON_STATES[s.state] if 0 <= s.state < len(_DAEMON_STATES) else str(s.state),
        threads=s.threads, queue_depth=s.queue_depth, queue_capacity=s.queue_capacity,
        memory_used=s.memory_used, memory_budget=s.memory_budget, served=dict(zip(_SERVED, s.served)),
        malformed=s.malformed, duplicates_answered=s.duplicates_answered, duplicates_joined=s.duplicates_joined,
        replies_by_status=replies, latency_p50_us=s.latency_p50_us, latency_p99_us=s.latency_p99_us,
        latency_count=s.latency_count, worlds=[_world(s.worlds[i]) for i in range(s.num_worlds)],
        loads=[_load(s.loads[i]) for i in range(s.num_loads)])


def _load(p):
    """A build under way, as a dict of trioct_load_progress's fields."""
    return {"world": _str(p.world), "client_id": p.client_id, "request_id": p.request_id,
            "phase": p.phase.decode("utf-8", "replace"), "files_done": p.files_done,
            "files_total": p.files_total, "triangles": p.triangles, "elapsed_seconds": p.elapsed_seconds}


class _Names:
    """One table of object names across a batch's requests: each reply numbers only the
    objects it names, so its indexes are mapped into the batch's table."""

    def __init__(self):
        self.names = []
        self._index = {}

    def mapping(self, objects):
        m = np.empty(objects.count, dtype=np.int32)
        for i in range(objects.count):
            name = objects.names[i].value.decode("utf-8", "replace")
            if name not in self._index:
                self._index[name] = len(self.names)
                self.names.append(name)
            m[i] = self._index[name]
        return m


class _ObjectIndexed:
    """Results whose .object indexes .objects, -1 where no object is named."""

    def object_names(self):
        """The object's name for each item (ray, point or pose), None where none is named:
        a miss, nothing found, or a clear pose."""
        return [self.objects[i] if i >= 0 else None for i in self.object]


class RayResult(_ObjectIndexed):
    """The answers of a batch of N rays, each array indexed by ray:

    hit       bool (N,): the ray met the world in [tmin, tmax]
    t         float64 (N,): the hit's parameter (the closest one's, or with any=True the
              one found first); NaN on a miss
    point     float64 (N, 3): origin + t * direction; NaN on a miss
    normal    float64 (N, 3): the unit normal of the triangle hit; NaN on a miss
    triangle  int32 (N,): the triangle's index in its object's mesh; -1 on a miss
    object    int32 (N,): the object hit, an index into .objects; -1 on a miss
    u, v      float64 (N,): barycentric weights of the triangle's vertices b and c; NaN
    objects   tuple of the object names the hits index
    requests  how many requests the batch took
    world_versions  the world's versions that answered (one, unless it was rebuilt meanwhile)
    daemon    the daemon that answered
    """

    def __init__(self, n):
        self.hit = np.zeros(n, dtype=bool)
        self.t = np.full(n, np.nan)
        self.point = np.full((n, 3), np.nan)
        self.normal = np.full((n, 3), np.nan)
        self.triangle = np.full(n, -1, dtype=np.int32)
        self.object = np.full(n, -1, dtype=np.int32)
        self.u = np.full(n, np.nan)
        self.v = np.full(n, np.nan)
        self.objects = ()
        self.requests = 0
        self.world_versions = ()
        self.daemon = ""

    def __len__(self):
        return self.t.shape[0]

    def __repr__(self):
        return "RayResult(%d rays, %d hits)" % (len(self), int(self.hit.sum()))


_FEATURES = ("face", "edge", "vertex")


class ShapeDistanceResult(_ObjectIndexed):
    """A shape's distances to a world, one per pose (Client.shape_distance):

    found     bool (N,): something within the query's `within`
    distance, bound, lower, upper  float64 (N,): the exact distance lies in [lower, upper];
              0 exactly when the shape touches (NaN where not found)
    point     (N, 3): the world's witness; shape_point (N, 3): the shape's, posed
    object    int32 (N,): index into .objects; -1 where not found
    triangle, shape_triangle  int32 (N,): the two triangles; -1 where not found
    objects   tuple of the object names .object indexes
    """

    def __init__(self, n):
        self.found = np.zeros(n, dtype=bool)
        self.distance = np.full(n, np.nan)
        self.bound = np.full(n, np.nan)
        self.lower = np.full(n, np.nan)
        self.upper = np.full(n, np.nan)
        self.point = np.full((n, 3), np.nan)
        self.shape_point = np.full((n, 3), np.nan)
        self.object = np.full(n, -1, dtype=np.int32)
        self.triangle = np.full(n, -1, dtype=np.int32)
        self.shape_triangle = np.full(n, -1, dtype=np.int32)
        self.objects = ()

    def __len__(self):
        return self.distance.shape[0]


class ClearanceResult(_ObjectIndexed):
    """A shape's clearance, one per pose (Client.clear): clear bool (N,), and object int32
    (N,), the index into .objects of the object a pose could not be proven clear of (-1
    where clear)."""

    def __init__(self, n):
        self.clear = np.zeros(n, dtype=bool)
        self.object = np.full(n, -1, dtype=np.int32)
        self.objects = ()

    def __len__(self):
        return self.clear.shape[0]


class DistanceResult(_ObjectIndexed):
    """The answers of a batch of N points, each array indexed by point:

    found     bool (N,): something of the world lies within `within`
    distance  float64 (N,): the distance, NaN when not found
    bound     float64 (N,): its proven error: |distance - exact| <= bound
    lower, upper  float64 (N,): the exact distance lies in [lower, upper]
    point     float64 (N, 3): the nearest point of the world; NaN when not found
    object    int32 (N,): an index into .objects; -1 when not found
    triangle  int32 (N,): the triangle in that object's mesh; -1 when not found
    feature   list of "face", "edge" or "vertex" (None when not found)
    feature_index  int32 (N,): the edge (vertex k to k + 1 mod 3) or vertex; 0 for a face
    objects   tuple of the object names .object indexes
    requests, world_versions, daemon  as for RayResult

    inside    bool (N,): the point lies inside a solid object; its distance is then
              negative, its depth below the surface
    """

    def __init__(self, n):
        self.found = np.zeros(n, dtype=bool)
        self.distance = np.full(n, np.nan)
        self.bound = np.full(n, np.nan)
        self.lower = np.full(n, np.nan)
        self.upper = np.full(n, np.nan)
        self.point = np.full((n, 3), np.nan)
        self.object = np.full(n, -1, dtype=np.int32)
        self.triangle = np.full(n, -1, dtype=np.int32)
        self.feature = [None] * n
        self.feature_index = np.zeros(n, dtype=np.int32)
        self.inside = np.zeros(n, dtype=bool)
        self.objects = ()
        self.requests = 0
        self.world_versions = ()
        self.daemon = ""

    def __len__(self):
        return self.distance.shape[0]

    def __repr__(self):
        return "DistanceResult(%d points, %d found)" % (len(self), int(self.found.sum()))


# ---- the connection ------------------------------------------------------------------------------


def connect(url=None, prefix=None, key_file=None, timeout_ms=2000):
    """Joins an LCM bus and returns a Client.

    url         the LCM URL; None: $LCM_DEFAULT_URL, else LCM's default (the rule of the
                trioct command and of trioct_connect)
    prefix      the deployment's channel prefix; None: "TRIOCT"
    key_file    the daemon's admin key file, for load and unload; None: $TRIOCT_KEY_FILE
                when set, else changes go unsigned
    timeout_ms  each call's default timeout in milliseconds (< 0: no limit)
    """
    return Client(url=url, prefix=prefix, key_file=key_file, timeout_ms=timeout_ms)


class Client:
    """One libtrioct connection. Calls on it are serialised (a connection is used by one
    thread at a time), so it may be shared between threads; separate clients run in
    parallel. Use it as a context manager, or close() it."""

    def __init__(self, url=None, prefix=None, key_file=None, timeout_ms=2000):
        self.timeout_ms = _timeout(timeout_ms, 2000)
        # The encoded strings must outlive the call that reads them.
        keep = (_text(url, "url", True), _text(prefix, "prefix", True), _text(key_file, "key_file", True))
        opt = _lib.ConnectOptions(url=keep[0], prefix=keep[1], admin_key_file=keep[2])
        status = ctypes.c_int(0)
        err = ctypes.create_string_buffer(_lib.MAX_MESSAGE_LEN + 1)
        self._lock = threading.Lock()
        self._h = _lib.trioct_connect(ctypes.byref(opt), ctypes.byref(status), err, len(err))
        if not self._h:
            self._h = None
            raise error_for(status.value, err.value.decode("utf-8", "replace"))

    # -- lifetime --

    def close(self):
        """Leaves the bus. Safe twice; the client cannot be used afterwards."""
        with self._lock:
            h, self._h = self._h, None
            if h:
                _lib.trioct_disconnect(h)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            if getattr(self, "_h", None):
                _lib.trioct_disconnect(self._h)
                self._h = None
        except Exception:  # interpreter shutdown: the module may be half torn down
            pass

    def _handle(self):
        if self._h is None:
            raise TransportError(Status.ERR_TRANSPORT, "the connection is closed")
        return self._h

    @property
    def closed(self):
        return self._h is None

    @property
    def url(self):
        """The bus, as the library names it (the $LCM_DEFAULT_URL rule applied)."""
        with self._lock:
            return _lib.trioct_url(self._handle()).decode()

    @property
    def prefix(self):
        with self._lock:
            return _lib.trioct_prefix(self._handle()).decode()

    @property
    def client_id(self):
        with self._lock:
            return _lib.trioct_client_id(self._handle())

    def __repr__(self):
        if self._h is None:
            return "<trioct.Client closed>"
        return "<trioct.Client %s prefix %s>" % (self.url, self.prefix)

    # -- rays --

    def rays(self, world, origins, dirs, *, tmin=0.0, tmax=math.inf, any=False, touch=False,
             accuracy=None, timeout_ms=None):
        """Casts rays origin + t * dir, t in [tmin, tmax], at world.

        origins, dirs  (N, 3) arrays (or (3,) for one origin or direction shared by all)
        any            True: each ray's first hit found, not the closest (cheaper)
        touch          True: every triangle the segment shares a point with counts (edges,
                       vertices, faces it lies in), not only crossings: a conservative
                       line-of-sight test; decided exactly
        accuracy       None or 'world' (the world's own mode), 'exact', 'seed' or 'fast'
        timeout_ms     per request; None: the client's

        Returns a RayResult. Any number of rays: the batch is cut into requests of at most
        TRIOCT_MAX_RAYS and the answers joined in order."""
        w = _text(world, "world")
        o, d = _ray_arrays(origins, dirs)
        n = o.shape[0]
        q = _lib.trioct_ray_query_default(w)
        q.detail = _lib.RAY_ANY if any else _lib.RAY_CLOSEST
        q.accuracy = _accuracy(accuracy)
        q.tmin = float(tmin)
        q.tmax = float(tmax)
        contact = _lib.CONTACT_TOUCH if touch else _lib.CONTACT_CROSSING
        out = RayResult(n)
        names = _Names()
        versions = []
        with self._lock:
            h = self._handle()
            timeout = _timeout(timeout_ms, self.timeout_ms)
            done = 0
            while True:
                k = min(n - done, _lib.MAX_RAYS)
                q.count = k
                q.origins = o.ctypes.data + done * 24 if k else None
                q.directions = d.ctypes.data + done * 24 if k else None
                res = _lib.RayResult()
                rc = _lib.trioct_rays_contact(h, ctypes.byref(q), contact, timeout, ctypes.byref(res))
                try:
                    if rc != Status.OK:
                        part = "rays %d..%d of %d" % (done, done + k - 1, n) if k < n else None
                        raise _failure(res.reply, part)
                    self._take_hits(out, res, done, k, names)
                    versions.append(res.reply.world_version)
                    out.daemon = _str(res.reply.daemon)
                finally:
                    _lib.trioct_ray_result_free(ctypes.byref(res))
                out.requests += 1
                done += k
                if done >= n:
                    break
        out.objects = tuple(names.names)
        out.world_versions = tuple(sorted(set(versions)))
        out.point = o + out.t[:, None] * d
        return out

    @staticmethod
    def _take_hits(out, res, offset, k, names):
        if res.num_hits == 0:
            return
        hits = _records(res.hits, res.num_hits, _lib.RayHit)
        ray = hits["ray"].astype(np.int64)
        obj = hits["object"].astype(np.int64)
        if ray.min() < 0 or ray.max() >= k or obj.min() < 0 or obj.max() >= res.objects.count:
            raise error_for(Status.ERR_BAD_REPLY, "a hit names a ray or object outside the reply")
        # Hits come by ray, then by increasing t: reversed, the assignment keeps each ray's
        # first (closest) one.
        idx = ray[::-1] + offset
        out.hit[idx] = True
        out.t[idx] = hits["t"][::-1]
        out.triangle[idx] = hits["triangle"][::-1]
        out.object[idx] = names.mapping(res.objects)[obj[::-1]]
        out.u[idx] = hits["u"][::-1]
        out.v[idx] = hits["v"][::-1]
        normal = hits["normal"][::-1]
        out.normal[idx] = np.stack([normal["x"], normal["y"], normal["z"]], axis=1)

    # -- a shape at poses --

    def mesh(self, world, shape, poses, *, accuracy=None, timeout_ms=None):
        """Whether a query shape touches the world at each pose: a bool array, one a pose.

        shape  the name of a query shape the world's scene registers, or inline triangles
               as an (M, 3, 3) array (at most TRIOCT_MAX_INLINE_SHAPE_TRIANGLES)
        poses  (N, 3) translations, (N, 7) x y z qw qx qy qz, or (N, 3, 4) / (N, 4, 4)
               matrices [R | t] (p' = R p + t); one pose may drop the leading N

        Any number of poses: the batch is cut into requests of at most TRIOCT_MAX_POSES."""
        w = _text(world, "world")
        if isinstance(shape, str):
            shape_name, tris = _text(shape, "shape"), None
        else:
            shape_name, tris = None, _triangles(shape)
        p = _poses(poses)
        n = p.shape[0]
        q = _lib.MeshQuery(world=w, detail=_lib.MESH_YESNO, accuracy=_accuracy(accuracy), shape=shape_name)
        if tris is not None:
            q.num_shape_triangles = tris.shape[0]
            q.shape_triangles = tris.ctypes.data if tris.shape[0] else None
        out = np.zeros(n, dtype=bool)
        with self._lock:
            h = self._handle()
            timeout = _timeout(timeout_ms, self.timeout_ms)
            done = 0
            while True:
                k = min(n - done, _lib.MAX_POSES)
                q.num_poses = k
                q.poses = p.ctypes.data + done * 96 if k else None
                res = _lib.MeshResult()
                rc = _lib.trioct_mesh(h, ctypes.byref(q), timeout, ctypes.byref(res))
                try:
                    if rc != Status.OK:
                        part = "poses %d..%d of %d" % (done, done + k - 1, n) if k < n else None
                        raise _failure(res.reply, part)
                    if k:
                        out[done:done + k] = _records(res.found, k, ctypes.c_int32) > 0
                finally:
                    _lib.trioct_mesh_result_free(ctypes.byref(res))
                done += k
                if done >= n:
                    break
        return out

    def distance(self, world, points, *, within=None, timeout_ms=None):
        """The nearest point of the world to each point, as `trioct distance` asks it.

        points  (N, 3), or (3,) for one point
        within  look no farther than this (>= 0); None: no limit

        Any number of points: the batch is cut into requests of at most TRIOCT_MAX_POINTS.
        The world must serve distance. Returns a DistanceResult."""
        w = _text(world, "world")
        p, _ = _points(points, "points")
        p = np.ascontiguousarray(p, dtype=np.float64)
        if within is not None and not (float(within) >= 0):
            raise ValueError("within must be a distance >= 0, not %r" % (within,))
        n = p.shape[0]
        out = DistanceResult(n)
        names = _Names()
        versions = []
        q = _lib.PointDistanceQuery(world=w, within=-1.0 if within is None else float(within))
        with self._lock:
            h = self._handle()
            timeout = _timeout(timeout_ms, self.timeout_ms)
            done = 0
            while True:
                k = min(n - done, _lib.MAX_POINTS)
                q.count = k
                q.points = p.ctypes.data + done * 24 if k else None
                res = _lib.DistanceResult()
                rc = _lib.trioct_point_distance(h, ctypes.byref(q), timeout, ctypes.byref(res))
                try:
                    if rc != Status.OK:
                        part = "points %d..%d of %d" % (done, done + k - 1, n) if k < n else None
                        raise _failure(res.reply, part)
                    m = names.mapping(res.objects)
                    for i in range(k):
                        d = res.results[i]
                        if not d.found:
                            continue
                        j = done + i
                        out.found[j] = True
                        out.distance[j], out.bound[j] = d.distance, d.bound
                        out.lower[j], out.upper[j] = d.lower, d.upper
                        out.point[j] = (d.point.x, d.point.y, d.point.z)
                        out.object[j] = m[d.object]
                        out.triangle[j] = d.triangle
                        out.feature[j] = _FEATURES[d.feature] if 0 <= d.feature < 3 else "unknown"
                        out.feature_index[j] = d.feature_index
                        out.inside[j] = bool(d.inside)
                    out.requests += 1
                    out.daemon = _str(res.reply.daemon)
                    if res.reply.world_version not in versions:
                        versions.append(res.reply.world_version)
                finally:
                    _lib.trioct_distance_result_free(ctypes.byref(res))
                done += k
                if done >= n:
                    break
        out.objects = tuple(names.names)
        out.world_versions = tuple(versions)
        return out

    def _shape_distances(self, call, world, shape, poses, within, timeout_ms, take):
        """Asks a shape at poses in requests of at most TRIOCT_MAX_POSES, take(j, d, m) per
        result (m maps the reply's object indexes to the batch's names)."""
        w = _text(world, "world")
        if isinstance(shape, str):
            shape_name, tris = _text(shape, "shape"), None
        else:
            shape_name, tris = None, _triangles(shape)
        p = _poses(poses)
        n = p.shape[0]
        names = _Names()
        q = _lib.ShapeDistanceQuery(world=w, within=within, shape=shape_name)
        if tris is not None:
            q.num_shape_triangles = tris.shape[0]
            q.shape_triangles = tris.ctypes.data if tris.shape[0] else None
        with self._lock:
            h = self._handle()
            timeout = _timeout(timeout_ms, self.timeout_ms)
            done = 0
            while done < n:
                k = min(n - done, _lib.MAX_POSES)
                q.num_poses = k
                q.poses = p.ctypes.data + done * 96
                res = _lib.DistanceResult()
                rc = call(h, ctypes.byref(q), timeout, ctypes.byref(res))
                try:
                    if rc != Status.OK:
                        part = "poses %d..%d of %d" % (done, done + k - 1, n) if k < n else None
                        raise _failure(res.reply, part)
                    m = names.mapping(res.objects)
                    for i in range(k):
                        take(done + i, res.results[i], m)
                finally:
                    _lib.trioct_distance_result_free(ctypes.byref(res))
                done += k
        return n, tuple(names.names)

    def shape_distance(self, world, shape, poses, *, within=None, timeout_ms=None):
        """The minimum distance between a query shape at each pose and the world, as
        `trioct distance WORLD --shape` asks it: a ShapeDistanceResult.

        shape, poses  as for mesh()
        within        look no farther than this (>= 0); None: no limit"""
        if within is not None and not (float(within) >= 0):
            raise ValueError("within must be a distance >= 0, not %r" % (within,))
        n = _poses(poses).shape[0]
        out = ShapeDistanceResult(n)

        def take(j, d, m):
            if not d.found:
                return
            out.found[j] = True
            out.distance[j], out.bound[j] = d.distance, d.bound
            out.lower[j], out.upper[j] = d.lower, d.upper
            out.point[j] = (d.point.x, d.point.y, d.point.z)
            out.shape_point[j] = (d.shape_point.x, d.shape_point.y, d.shape_point.z)
            out.object[j] = m[d.object]
            out.triangle[j] = d.triangle
            out.shape_triangle[j] = d.shape_triangle

        _, out.objects = self._shape_distances(_lib.trioct_shape_distance, world, shape, poses,
                                               -1.0 if within is None else float(within), timeout_ms, take)
        return out

    def clear(self, world, shape, poses, within, *, timeout_ms=None):
        """Whether the shape at each pose is clear of the world by more than `within`, as
        `trioct clear` asks it: a ClearanceResult (never clear when the exact distance is
        `within` or less)."""
        if not (float(within) >= 0):
            raise ValueError("within must be a radius >= 0, not %r" % (within,))
        n = _poses(poses).shape[0]
        out = ClearanceResult(n)

        def take(j, d, m):
            out.clear[j] = bool(d.clear)
            if not d.clear and d.object >= 0:
                out.object[j] = m[d.object]

        _, out.objects = self._shape_distances(_lib.trioct_clearance, world, shape, poses, float(within),
                                               timeout_ms, take)
        return out

    # -- worlds --

    def _admin(self, call, timeout_ms, *args):
        res = _lib.AdminResult()
        with self._lock:
            rc = call(self._handle(), *args, _timeout(timeout_ms, self.timeout_ms), ctypes.byref(res))
        try:
            if rc != Status.OK:
                raise _failure(res.reply)
            return [_world(res.worlds[i]) for i in range(res.num_worlds)]
        finally:
            _lib.trioct_admin_result_free(ctypes.byref(res))

    def info(self, world, *, timeout_ms=None):
        """The world's WorldInfo, from the daemon holding it."""
        worlds = self._admin(_lib.trioct_info, timeout_ms, _text(world, "world"))
        if not worlds:
            raise error_for(Status.ERR_BAD_REPLY, "INFO of %s answered without the world" % world)
        return worlds[0]

    def worlds(self, *, gather_ms=1000, expect_daemons=0, timeout_ms=None):
        """Every daemon's worlds on the bus, as WorldInfo (each with .daemon). Answers are
        gathered for gather_ms, or until expect_daemons daemons answered. NoReply when no
        daemon answered."""
        opt = _lib.ListOptions(gather_ms=int(gather_ms), expect_daemons=int(expect_daemons))
        res = _lib.ListResult()
        with self._lock:
            rc = _lib.trioct_list(self._handle(), ctypes.byref(opt), _timeout(timeout_ms, self.timeout_ms),
                                  ctypes.byref(res))
        try:
            if rc != Status.OK:
                raise _failure(res.reply)
            return [_world(res.worlds[i]) for i in range(res.num_worlds)]
        finally:
            _lib.trioct_list_result_free(ctypes.byref(res))

    def load(self, world, *, mesh=None, daemon=None, resolution=None, accuracy=None, effects=None,
             timeout_ms=60000):
        """Builds (or rebuilds) a world on a daemon (default "trioctd") and returns its
        WorldInfo once built: the scene's section named world, or with mesh a file in the
        daemon's world directory. Needs the daemon's admin key (connect's key_file)."""
        opt = _lib.LoadOptions(world=_text(world, "world"), daemon=_text(daemon, "daemon", True),
                               mesh_path=_text(mesh, "mesh", True),
                               resolution=0.0 if resolution is None else float(resolution),
                               accuracy=_accuracy(accuracy), effects=_effects(effects))
        worlds = self._admin(_lib.trioct_load, timeout_ms, ctypes.byref(opt))
        return worlds[0] if worlds else None

    def unload(self, world, *, timeout_ms=None):
        """Drops a world from the daemon holding it (needs the admin key)."""
        self._admin(_lib.trioct_unload, timeout_ms, _text(world, "world"))

    def status(self, daemon=None, *, timeout_ms=None):
        """The next heartbeat heard (from daemon, or from any), as DaemonStatus."""
        res = _lib.DaemonStatus()
        with self._lock:
            rc = _lib.trioct_next_status(self._handle(), _text(daemon, "daemon", True),
                                         _timeout(timeout_ms, self.timeout_ms), ctypes.byref(res))
        try:
            if rc != Status.OK:
                raise _failure(res.reply)
            return _daemon_status(res)
        finally:
            _lib.trioct_daemon_status_free(ctypes.byref(res))
