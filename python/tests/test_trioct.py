"""The trioct Python package against a real trioctd over udpm, inside the private network
and pid namespace of tests/e2e/netns.sh (make test runs it there):

    tests/e2e/netns.sh env PYTHONPATH=build/python TRIOCT_BUILD=build \\
        /usr/bin/python3 -m unittest discover -v -s python/tests

The daemon serves a box whose triangles this file writes, so every answer is known from
the geometry: a ray straight down at (x, y) from z = 10 meets the top face z = 2 at t = 8,
in triangle 1 where y > x and triangle 0 where y < x, with normal (0, 0, 1); the unit cube
shape at a translation touches the box's surface exactly when the closed solids meet and
the cube is not inside the box's open interior. LCM must never reach a real network: the
tests that need the bus refuse to run (SKIPPED, which make test counts as a failure as
root) when this network namespace has any interface but lo.

TRIOCT_BUILD names the build directory (default build), TRIOCT_DAEMON the daemon (default
BUILD/trioctd), TRIOCT_SEED the seed of the randomised batches (printed).
"""

import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import numpy as np

import trioct

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD = os.path.join(REPO, os.environ.get("TRIOCT_BUILD", "build"))
DAEMON_BIN = os.environ.get("TRIOCT_DAEMON", os.path.join(BUILD, "trioctd"))
URL = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
DAEMON = "pyd"
KEY_HEX = "a0a1a2a3a4a5a6a7a8a9aaabacadaeafb0b1b2b3b4b5b6b7b8b9babbbcbdbebf"
SEED = int(os.environ.get("TRIOCT_SEED", str(int.from_bytes(os.urandom(4), "little"))))

# The box [0,4] x [0,4] x [0,2], outward normals. Triangle ids: 0, 1 the top (0 where
# y < x), 2, 3 the bottom, then the four sides.
BOX_OBJ = """v 0 0 0
v 4 0 0
v 4 4 0
v 0 4 0
v 0 0 2
v 4 0 2
v 4 4 2
v 0 4 2
f 5 6 7
f 5 7 8
f 1 3 2
f 1 4 3
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
"""
# The query shape: the unit cube [-0.5, 0.5]^3, the same faces.
CUBE_OBJ = """v -0.5 -0.5 -0.5
v 0.5 -0.5 -0.5
v 0.5 0.5 -0.5
v -0.5 0.5 -0.5
v -0.5 -0.5 0.5
v 0.5 -0.5 0.5
v 0.5 0.5 0.5
v -0.5 0.5 0.5
""" + BOX_OBJ[BOX_OBJ.index("f "):]
SCENE = """[box]
mesh = box.obj
effects = rays triangles meshes distance
shape.cube = cube.obj

[box_tri]
mesh = box.obj
effects = triangles
"""


def private_network():
    """Whether this process's network namespace has no interface but lo (/proc/net/dev
    lists the reader's own namespace's)."""
    try:
        with open("/proc/net/dev") as f:
            names = [line.split(":")[0].strip() for line in f.readlines()[2:]]
    except OSError:
        return False
    return names == ["lo"]


def daemon_env():
    """This process's environment without LD_PRELOAD: a sanitized build's runtime preloaded
    into this interpreter is not for the daemon, which links its own (and whose confined
    mesh loader could not reserve the runtime's address space)."""
    env = dict(os.environ)
    env.pop("LD_PRELOAD", None)
    return env


def cube_touches(t):
    """Whether the unit cube translated by t touches the box's surface: the closed solids
    meet and the cube is not inside the box's open interior (it cannot contain the box)."""
    lo, hi = np.asarray(t) - 0.5, np.asarray(t) + 0.5
    box_hi = np.array([4.0, 4.0, 2.0])
    meet = np.all(lo <= box_hi, axis=-1) & np.all(hi >= 0.0, axis=-1)
    inside = np.all(lo > 0.0, axis=-1) & np.all(hi < box_hi, axis=-1)
    return meet & ~inside


# ---- without a daemon ------------------------------------------------------------------------------


class TestPackage(unittest.TestCase):
    def test_library_from_build_tree(self):
        """Imported from the build tree, the package loads the build's libtrioct.so.4."""
        self.assertNotIn("TRIOCT_LIBRARY", os.environ)
        self.assertTrue(os.path.samefile(trioct.library_path, os.path.join(BUILD, "libtrioct.so.4")),
                        trioct.library_path)
        self.assertTrue(os.path.samefile(os.path.dirname(trioct.__file__), os.path.join(BUILD, "python", "trioct")))

    def test_struct_layout(self):
        """Every ctypes struct has the size and field offsets of its C twin in trioct.h."""
        from trioct import _lib
        lines = ["#include <stddef.h>", "#include <stdio.h>", '#include "trioct.h"', "int main(void) {"]
        want = []
        for s in _lib.STRUCTS:
            lines.append('printf("%%s %%zu\\n", "%s", sizeof(%s));' % (s._c_name_, s._c_name_))
            want.append("%s %d" % (s._c_name_, __import__("ctypes").sizeof(s)))
            for name, _ in s._fields_:
                lines.append('printf("%%s.%%s %%zu\\n", "%s", "%s", offsetof(%s, %s));'
                             % (s._c_name_, name, s._c_name_, name))
                want.append("%s.%s %d" % (s._c_name_, name, getattr(s, name).offset))
        lines.append("return 0; }")
        tmp = tempfile.mkdtemp(prefix="trioct_py_layout_")
        try:
            src, exe = os.path.join(tmp, "layout.c"), os.path.join(tmp, "layout")
            with open(src, "w") as f:
                f.write("\n".join(lines) + "\n")
            subprocess.run(["cc", "-std=c11", "-Wall", "-Werror", "-I", os.path.join(REPO, "client"), "-I",
                            os.path.join(REPO, "common"), src, "-o", exe], check=True)
            got = subprocess.run([exe], check=True, capture_output=True, text=True).stdout.split("\n")[:-1]
        finally:
            shutil.rmtree(tmp)
        self.assertGreater(len(want), 100)
        self.assertEqual(got, want)

    def test_status_table_is_the_headers(self):
        with open(os.path.join(REPO, "common", "trioct_status.h")) as f:
            table = re.findall(r'X\(TRIOCT_([A-Z0-9_]+), (\d+), "([^"]*)"\)', f.read())
        self.assertGreater(len(table), 20)
        self.assertEqual([(s.name, s.value) for s in trioct.Status], [(n, int(c)) for n, c, _ in table])
        for name, code, text in table:
            self.assertEqual(trioct.status_text(int(code)), text)
        self.assertEqual(trioct.status_name(2), "ERR_UNKNOWN_WORLD")
        self.assertEqual(trioct.status_name(99), "UNKNOWN")

    def test_errors_by_class(self):
        e = trioct.errors.error_for(2, "world w is not held", "d", "w")
        self.assertIsInstance(e, trioct.DaemonError)
        self.assertEqual((e.status, e.name, e.message, e.daemon), (trioct.Status.ERR_UNKNOWN_WORLD,
                                                                   "ERR_UNKNOWN_WORLD", "world w is not held", "d"))
        self.assertEqual(str(e), "ERR_UNKNOWN_WORLD: world w is not held")
        self.assertIsInstance(trioct.errors.error_for(101), trioct.NoReply)
        self.assertIsInstance(trioct.errors.error_for(100), trioct.NoReply)
        self.assertIsInstance(trioct.errors.error_for(102), trioct.TransportError)
        self.assertIsInstance(trioct.errors.error_for(103), trioct.BadReply)
        self.assertEqual(trioct.errors.error_for(104).status, 104)  # a newer code passes through

    def test_bad_connect(self):
        with self.assertRaises(trioct.DaemonError) as cm:
            trioct.connect(url="memq://", prefix="not-a-prefix")
        self.assertEqual(cm.exception.status, trioct.Status.ERR_BAD_REQUEST)
        self.assertIn("not-a-prefix", cm.exception.message)
        with self.assertRaises(trioct.DaemonError) as cm:
            trioct.connect(url="memq://", key_file="/nonexistent/trioct.key")
        self.assertEqual(cm.exception.status, trioct.Status.ERR_BAD_REQUEST)
        with self.assertRaises(TypeError):
            trioct.connect(url=5)

    def test_no_daemon_on_memq(self):
        """A private memq:// bus has nobody on it: NoReply naming the world, and a closed
        client refuses calls without touching the library."""
        c = trioct.connect("memq://", timeout_ms=50)
        with self.assertRaises(trioct.NoReply) as cm:
            c.rays("nowhere", [[0, 0, 1]], [[0, 0, -1]])
        self.assertEqual(cm.exception.status, trioct.Status.ERR_NO_DAEMON)
        self.assertIn("nowhere", cm.exception.message)
        c.close()
        c.close()
        with self.assertRaises(trioct.TransportError):
            c.rays("nowhere", [[0, 0, 1]], [[0, 0, -1]])


# ---- against the daemon ----------------------------------------------------------------------------


class TestDaemon(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if not private_network():
            print("SKIPPED: the daemon tests use udpm, which runs only in a private network namespace "
                  "(tests/e2e/netns.sh)")
            raise unittest.SkipTest("not in a private network namespace")
        print("test_trioct: TRIOCT_SEED=%d" % SEED)
        os.environ.pop("TRIOCT_KEY_FILE", None)
        os.environ.pop("TRIOCT_LIBRARY", None)
        cls.dir = tempfile.mkdtemp(prefix="trioct_py_")
        for name, text in (("box.obj", BOX_OBJ), ("cube.obj", CUBE_OBJ), ("scene.ini", SCENE)):
            with open(os.path.join(cls.dir, name), "w") as f:
                f.write(text)
        cls.key = os.path.join(cls.dir, "admin.key")
        fd = os.open(cls.key, os.O_WRONLY | os.O_CREAT, 0o600)
        os.write(fd, (KEY_HEX + "\n").encode())
        os.close(fd)
        cls.log = open(os.path.join(cls.dir, "daemon.log"), "w")
        cls.daemon = subprocess.Popen(
            [DAEMON_BIN, "--scene", os.path.join(cls.dir, "scene.ini"), "--world-dir", cls.dir, "--url", URL,
             "--name", DAEMON, "--threads", "2", "--status-interval", "200", "--admin-key-file", cls.key],
            stdout=cls.log, stderr=subprocess.STDOUT, env=daemon_env())
        cls.c = trioct.connect(URL, timeout_ms=5000)
        deadline = time.monotonic() + 20
        while True:
            try:
                if cls.c.status(DAEMON, timeout_ms=500).state == "ready":
                    break
            except trioct.NoReply:
                pass
            if time.monotonic() > deadline or cls.daemon.poll() is not None:
                cls.tearDownClass()
                raise RuntimeError("trioctd did not report ready; its log:\n" + cls.daemon_log())

    @classmethod
    def daemon_log(cls):
        with open(os.path.join(cls.dir, "daemon.log")) as f:
            return f.read()

    @classmethod
    def tearDownClass(cls):
        cls.c.close()
        if cls.daemon.poll() is None:
            cls.daemon.send_signal(signal.SIGTERM)
            try:
                cls.daemon.wait(10)
            except subprocess.TimeoutExpired:
                cls.daemon.kill()
                cls.daemon.wait()
        cls.log.close()
        shutil.rmtree(cls.dir)

    # -- rays --

    def down_at(self, xy, z=10.0):
        xy = np.asarray(xy, dtype=float)
        return np.column_stack([xy, np.full(len(xy), z)]), np.tile([0.0, 0.0, -1.0], (len(xy), 1))

    def test_rays_down_onto_the_top(self):
        xs = np.arange(0.25, 4.0, 0.5)
        xy = np.array([(x, y) for x in xs for y in xs + 0.125])
        o, d = self.down_at(xy)
        r = self.c.rays("box", o, d)
        self.assertEqual(len(r), len(xy))
        self.assertTrue(r.hit.all())
        np.testing.assert_array_equal(r.t, np.full(len(xy), 8.0))
        np.testing.assert_array_equal(r.point, np.column_stack([xy, np.full(len(xy), 2.0)]))
        np.testing.assert_array_equal(r.normal, np.tile([0.0, 0.0, 1.0], (len(xy), 1)))
        upper = xy[:, 1] > xy[:, 0]
        np.testing.assert_array_equal(r.triangle, np.where(upper, 1, 0))
        self.assertEqual(r.objects, ("box",))
        np.testing.assert_array_equal(r.object, np.zeros(len(xy)))
        self.assertEqual(r.object_names(), ["box"] * len(xy))
        # Barycentric weights of vertices b and c: (4,0,2), (4,4,2) for triangle 0 and
        # (4,4,2), (0,4,2) for triangle 1, vertex a at (0,0,2).
        x, y = xy[:, 0], xy[:, 1]
        np.testing.assert_allclose(r.u, np.where(upper, x / 4, (x - y) / 4), rtol=0, atol=1e-15)
        np.testing.assert_allclose(r.v, np.where(upper, (y - x) / 4, y / 4), rtol=0, atol=1e-15)
        self.assertEqual(r.requests, 1)
        self.assertEqual(r.daemon, DAEMON)
        self.assertEqual(len(r.world_versions), 1)

    def test_t_is_the_rays_parameter(self):
        r = self.c.rays("box", [[1, 3, 10], [1, 3, 10], [3, 1, 1]], [[0, 0, -2], [0, 0, -0.5], [0, 0, 1]])
        np.testing.assert_array_equal(r.t, [4.0, 16.0, 1.0])
        np.testing.assert_array_equal(r.point, [[1, 3, 2], [1, 3, 2], [3, 1, 2]])
        # From inside, the top's outward normal all the same.
        np.testing.assert_array_equal(r.normal[2], [0, 0, 1])

    def test_misses_are_nan(self):
        o = [[5, 1, 10], [1, 3, 10], [1, 3, 10], [-1, 2, 10]]
        d = [[0, 0, -1], [0, 0, -1], [0, 0, 1], [0, 0, -1]]
        r = self.c.rays("box", o, d)
        np.testing.assert_array_equal(r.hit, [False, True, False, False])
        miss = ~r.hit
        self.assertTrue(np.isnan(r.t[miss]).all())
        self.assertTrue(np.isnan(r.point[miss]).all())
        self.assertTrue(np.isnan(r.normal[miss]).all())
        self.assertTrue(np.isnan(r.u[miss]).all() and np.isnan(r.v[miss]).all())
        np.testing.assert_array_equal(r.triangle[miss], -1)
        np.testing.assert_array_equal(r.object[miss], -1)
        self.assertEqual(r.object_names(), [None, "box", None, None])
        self.assertEqual((r.t[1], r.triangle[1]), (8.0, 1))

    def test_window_any_and_touch(self):
        o, d = [[1, 3, 10]], [[0, 0, -1]]
        self.assertFalse(self.c.rays("box", o, d, tmax=7.5).hit[0])
        self.assertEqual(self.c.rays("box", o, d, tmin=9).t[0], 10.0)  # past the top: the bottom
        self.assertIn(self.c.rays("box", o, d, any=True).t[0], (8.0, 10.0))
        # In the top face's plane, over the box: a touch from where it meets the box's edge
        # (closest; any=True may name a triangle the segment meets later).
        touch = self.c.rays("box", [[-1, 1, 2]], [[1, 0, 0]], touch=True)
        self.assertTrue(touch.hit[0])
        self.assertEqual(touch.t[0], 1.0)
        self.assertTrue(self.c.rays("box", [[-1, 1, 2]], [[1, 0, 0]], touch=True, any=True).hit[0])
        self.assertFalse(self.c.rays("box", [[-1, 1, 2.5]], [[1, 0, 0]], touch=True).hit[0])
        self.assertEqual(self.c.rays("box", o, d, accuracy="fast").t[0], 8.0)

    def test_shared_origin_and_empty_batch(self):
        dirs = [[-1, 0.5, -8], [0, 0, -1], [1, 0, -8], [0, 1, -4]]
        r = self.c.rays("box", [2, 1, 10], dirs)
        np.testing.assert_array_equal(r.t, [1.0, 8.0, 1.0, 2.0])
        np.testing.assert_array_equal(r.point, [[1, 1.5, 2], [2, 1, 2], [3, 1, 2], [2, 3, 2]])
        np.testing.assert_array_equal(r.triangle, [1, 0, 0, 1])
        r = self.c.rays("box", np.zeros((0, 3)), np.zeros((0, 3)))
        self.assertEqual((len(r), r.requests, r.point.shape), (0, 1, (0, 3)))

    def test_batch_over_the_cap_equals_one_ray_at_a_time(self):
        rng = np.random.RandomState(SEED)
        n = 2 * trioct.MAX_RAYS + 377
        o = np.column_stack([rng.uniform(-1, 5, n), rng.uniform(-1, 5, n), rng.uniform(3, 12, n)])
        d = np.column_stack([rng.uniform(-0.2, 0.2, n), rng.uniform(-0.2, 0.2, n), -rng.uniform(0.5, 2, n)])
        r = self.c.rays("box", o, d)
        self.assertEqual(r.requests, 3)
        self.assertEqual(len(r), n)
        self.assertTrue(0 < r.hit.sum() < n)
        each = [self.c.rays("box", o[i], d[i]) for i in range(n)]
        np.testing.assert_array_equal(r.hit, [e.hit[0] for e in each])
        for field in ("t", "triangle", "object", "u", "v"):
            np.testing.assert_array_equal(getattr(r, field), [getattr(e, field)[0] for e in each], field)
        for field in ("point", "normal"):
            np.testing.assert_array_equal(getattr(r, field), [getattr(e, field)[0] for e in each], field)
        # And the geometry: every hit where the ray crosses z = 2 over the top is that one.
        t_top = (2.0 - o[:, 2]) / d[:, 2]
        p = o + t_top[:, None] * d
        over = (p[:, 0] > 1e-9) & (p[:, 0] < 4 - 1e-9) & (p[:, 1] > 1e-9) & (p[:, 1] < 4 - 1e-9)
        self.assertGreater(over.sum(), n // 4)
        np.testing.assert_array_equal(r.hit[over], True)
        np.testing.assert_allclose(r.t[over], t_top[over], rtol=1e-14)
        np.testing.assert_array_equal(r.normal[over], np.tile([0, 0, 1.0], (over.sum(), 1)))

    # -- a shape at poses --

    def test_shape_at_translations(self):
        t = [[2, 2, 2.4], [2, 2, 5], [2, 2, 1], [2, 2, 2.5], [4.5, 2, 1], [4.5000001, 2, 1], [-3, -3, -3]]
        got = self.c.mesh("box", "cube", t)
        self.assertEqual(got.dtype, bool)
        np.testing.assert_array_equal(got, [True, False, False, True, True, False, False])
        np.testing.assert_array_equal(got, cube_touches(np.array(t)))

    def test_shape_at_rotations(self):
        s = math.sqrt(0.5)
        w, k = math.cos(math.pi / 8), math.sin(math.pi / 8)
        # 45 degrees about x: the cube reaches 0.707 below its centre, into the top; about z
        # it keeps its 0.5, as unturned.
        q = [[2, 2, 2.6, w, k, 0, 0], [2, 2, 2.6, w, 0, 0, k], [2, 2, 2.6, 1, 0, 0, 0]]
        np.testing.assert_array_equal(self.c.mesh("box", "cube", q), [True, False, False])
        rx = np.eye(4)
        rx[:3, :3] = [[1, 0, 0], [0, s, -s], [0, s, s]]
        rx[:3, 3] = [2, 2, 2.6]
        np.testing.assert_array_equal(self.c.mesh("box", "cube", rx), [True])
        np.testing.assert_array_equal(self.c.mesh("box", "cube", rx[None, :3, :]), [True])
        self.assertTrue(self.c.mesh("box", "cube", q[0])[0])

    def test_inline_shape(self):
        tri = [[[-1, -1, 0], [1, -1, 0], [0, 1, 0]]]
        np.testing.assert_array_equal(self.c.mesh("box", tri, [[2, 2, 2], [2, 2, 3], [2, 2, 1]]),
                                      [True, False, False])
        self.assertTrue(self.c.mesh("box", tri[0], [2, 2, 2])[0])

    def test_poses_over_the_cap(self):
        g = np.arange(-1.0, 5.01, 0.25)
        rng = np.random.RandomState(SEED)
        n = 2 * trioct.MAX_POSES + 301
        t = np.column_stack([rng.choice(g, n), rng.choice(g, n), rng.choice(np.arange(-1.0, 3.01, 0.25), n)])
        got = self.c.mesh("box", "cube", t)
        want = cube_touches(t)
        self.assertTrue(0 < want.sum() < n)
        np.testing.assert_array_equal(got, want)

    # -- bad input --

    def test_wrong_shapes_raise_value_error(self):
        ok = [[0, 0, 1]]
        for origins, dirs in (([[0, 0]], [[0, 0]]), (ok, [[0, 0, 1], [0, 0, 1]]), (np.zeros((2, 3, 1)), ok),
                              ("abc", ok), (ok, [[0, 0, "x"]]), ([], ok), (np.zeros(4), ok)):
            with self.assertRaises(ValueError, msg="%r %r" % (origins, dirs)) as cm:
                self.c.rays("box", origins, dirs)
            self.assertRegex(str(cm.exception), "origins|dirs")
        with self.assertRaisesRegex(ValueError, r"\(N, 3\)"):
            self.c.rays("box", np.zeros((3, 2)), np.zeros((3, 2)))
        with self.assertRaisesRegex(ValueError, "origins has 1 rays and dirs 2"):
            self.c.rays("box", ok, [[0, 0, 1], [0, 0, 1]])
        for poses in (np.zeros((2, 5)), np.zeros((2, 4, 3)), np.zeros(6), [["a", 0, 0]]):
            with self.assertRaisesRegex(ValueError, "poses"):
                self.c.mesh("box", "cube", poses)
        with self.assertRaisesRegex(ValueError, "last row"):
            self.c.mesh("box", "cube", np.ones((1, 4, 4)))
        with self.assertRaisesRegex(ValueError, "shape"):
            self.c.mesh("box", np.zeros((2, 3, 2)), [0, 0, 0])
        with self.assertRaisesRegex(ValueError, "accuracy"):
            self.c.rays("box", ok, ok, accuracy="exactish")
        with self.assertRaises(TypeError):
            self.c.rays(None, ok, ok)
        with self.assertRaises(ValueError):
            self.c.rays("bo\0x", ok, ok)
        with self.assertRaises(trioct.DaemonError) as cm:  # refused by the library, named
            self.c.rays("not a name", ok, ok)
        self.assertEqual((cm.exception.status, cm.exception.daemon), (trioct.Status.ERR_BAD_REQUEST, ""))
        with self.assertRaises(trioct.DaemonError) as cm:
            self.c.mesh("box", "cube", [[0, 0, 0, 2, 0, 0, 0]])  # a quaternion of length 2
        self.assertEqual(cm.exception.status, trioct.Status.ERR_BAD_POSE)
        self.assertIn("pose 0", cm.exception.message)

    # -- the daemon's errors --

    def test_unknown_world_gets_no_reply(self):
        """Nothing holds it, so nothing answers: each daemon listens on its own worlds'
        channels only."""
        with self.assertRaises(trioct.NoReply) as cm:
            self.c.rays("nowhere", [[0, 0, 1]], [[0, 0, -1]], timeout_ms=300)
        self.assertEqual(cm.exception.status, trioct.Status.ERR_NO_DAEMON)
        self.assertIn("nowhere", cm.exception.message)
        with self.assertRaises(trioct.NoReply):
            self.c.info("nowhere", timeout_ms=300)

    def test_daemon_errors(self):
        cases = (
            (lambda: self.c.rays("box", [[1, 1, 5]], [[0, 0, 0]]), trioct.Status.ERR_ZERO_DIRECTION),
            (lambda: self.c.rays("box", [[1, 1, 5]], [[0, np.nan, -1]]), trioct.Status.ERR_NONFINITE),
            (lambda: self.c.rays("box_tri", [[1, 1, 5]], [[0, 0, -1]]), trioct.Status.ERR_EFFECT),
            (lambda: self.c.mesh("box", "sphere", [[0, 0, 0]]), trioct.Status.ERR_UNKNOWN_SHAPE),
            (lambda: self.c.mesh("box_tri", "cube", [[0, 0, 0]]), trioct.Status.ERR_EFFECT),
        )
        for call, status in cases:
            with self.assertRaises(trioct.DaemonError) as cm:
                call()
            self.assertEqual(cm.exception.status, status)
            self.assertEqual(cm.exception.name, status.name)
            self.assertEqual(cm.exception.daemon, DAEMON)
            self.assertTrue(cm.exception.message)

    def test_error_in_a_later_request_names_its_rays(self):
        o, d = self.down_at(np.full((2000, 2), 1.0))
        d[1500] = 0
        with self.assertRaises(trioct.DaemonError) as cm:
            self.c.rays("box", o, d)
        self.assertEqual(cm.exception.status, trioct.Status.ERR_ZERO_DIRECTION)
        self.assertTrue(cm.exception.message.startswith("rays 1280..1999 of 2000: "), cm.exception.message)

    # -- distance --

    def test_distance_face_edge_vertex(self):
        """The box [0,4] x [0,4] x [0,2]: distances known exactly, and their features."""
        r = self.c.distance("box", [[6, 1, 1.5], [7, -2, 1], [7, 7, 5], [2, 1, 1.5]])
        self.assertEqual(len(r), 4)
        self.assertTrue(r.found.all())
        want = [2.0, 13 ** 0.5, 27 ** 0.5, 0.5]
        for i, w in enumerate(want):
            self.assertLessEqual(abs(r.distance[i] - w), r.bound[i] + 1e-15)
            self.assertTrue(r.lower[i] <= r.distance[i] <= r.upper[i])
        self.assertEqual(r.feature[:3], ["face", "edge", "vertex"])
        self.assertEqual(tuple(r.point[0]), (4.0, 1.0, 1.5))
        self.assertEqual(tuple(r.point[2]), (4.0, 4.0, 2.0))
        self.assertEqual(r.object_names(), ["box"] * 4)
        self.assertIn(int(r.triangle[0]), (6, 7))  # the side x = 4
        self.assertEqual(r.requests, 1)

    def test_distance_within_and_one_point(self):
        r = self.c.distance("box", [6, 1, 1.5], within=1.5)
        self.assertFalse(r.found[0])
        self.assertTrue(np.isnan(r.distance[0]))
        self.assertEqual(r.object_names(), [None])
        self.assertIsNone(r.feature[0])
        r = self.c.distance("box", [6, 1, 1.5], within=2.5)
        self.assertTrue(r.found[0])
        with self.assertRaises(ValueError):
            self.c.distance("box", [6, 1, 1.5], within=-1)

    def test_distance_batch_over_the_cap(self):
        n = trioct.MAX_POINTS + 100
        pts = np.column_stack([np.linspace(5, 9, n), np.full(n, 1.0), np.full(n, 1.5)])
        r = self.c.distance("box", pts)
        self.assertEqual(r.requests, 2)
        self.assertTrue(np.all(np.abs(r.distance - (pts[:, 0] - 4)) <= r.bound + 1e-12))

    def test_shape_distance_and_clearance(self):
        """The cube [-0.5, 0.5]^3 over the box [0,4] x [0,4] x [0,2]: 2.5 above at z = 5,
        touching (0 exactly) at z = 2.4; clear of 0.05 at z = 2.6, not at its own distance."""
        r = self.c.shape_distance("box", "cube", [[2, 2, 5], [2, 2, 2.4]])
        self.assertEqual(len(r), 2)
        self.assertTrue(r.found.all())
        self.assertTrue(r.lower[0] <= 2.5 <= r.upper[0])
        self.assertEqual((r.lower[1], r.upper[1], r.distance[1]), (0.0, 0.0, 0.0))
        self.assertEqual(r.shape_point[0][2], 4.5)
        self.assertEqual(r.object_names(), ["box", "box"])
        self.assertTrue(0 <= r.shape_triangle[0] < 12 and 0 <= r.triangle[0] < 12)
        self.assertFalse(self.c.shape_distance("box", "cube", [2, 2, 5], within=1.0).found[0])
        above = (2.6 - 0.5) - 2
        c = self.c.clear("box", "cube", [[2, 2, 2.6], [2, 2, 5]], 0.05)
        np.testing.assert_array_equal(c.clear, [True, True])
        c = self.c.clear("box", "cube", [2, 2, 2.6], above)
        np.testing.assert_array_equal(c.clear, [False])
        self.assertEqual(c.object_names(), ["box"])
        with self.assertRaises(ValueError):
            self.c.clear("box", "cube", [2, 2, 2.6], -1)
        with self.assertRaises(trioct.DaemonError) as cm:
            self.c.shape_distance("box", "gripper", [2, 2, 5])
        self.assertEqual(cm.exception.status, trioct.Status.ERR_UNKNOWN_SHAPE)

    def test_distance_needs_the_effect(self):
        with self.assertRaises(trioct.DaemonError) as cm:
            self.c.distance("box_tri", [6, 1, 1.5])
        self.assertEqual(cm.exception.status, trioct.Status.ERR_EFFECT)
        self.assertIn("distance queries need effects = distance", cm.exception.message)

    # -- worlds, status, admin --

    def test_info_worlds_status(self):
        w = self.c.info("box")
        self.assertEqual((w.name, w.daemon, w.triangles, w.vertices, w.objects), ("box", DAEMON, 12, 8, 1))
        self.assertEqual(w.effects, {"rays", "triangles", "meshes", "distance"})
        self.assertEqual(w.shapes, ["cube"])
        self.assertEqual((w.bbox_min, w.bbox_max), ((0.0, 0.0, 0.0), (4.0, 4.0, 2.0)))
        self.assertEqual(w.accuracy, "exact")
        names = {(x.name, x.daemon) for x in self.c.worlds(expect_daemons=1)}
        self.assertTrue({("box", DAEMON), ("box_tri", DAEMON)} <= names, names)
        s = self.c.status(DAEMON)
        self.assertEqual((s.daemon, s.state, s.version), (DAEMON, "ready", trioct.__version__))
        self.assertGreater(s.served["ray"], 0)
        self.assertGreater(s.replies_by_status[trioct.Status.OK], 0)
        self.assertTrue({"box", "box_tri"} <= {x.name for x in s.worlds})

    def test_load_and_unload(self):
        with self.assertRaises(trioct.DaemonError) as cm:
            self.c.load("extra", mesh="box.obj", daemon=DAEMON)
        self.assertEqual(cm.exception.status, trioct.Status.ERR_DENIED)
        with trioct.connect(URL, key_file=self.key, timeout_ms=5000) as admin:
            w = admin.load("extra", mesh="box.obj", daemon=DAEMON, effects="rays")
            self.assertEqual((w.name, w.triangles, w.effects), ("extra", 12, {"rays"}))
            self.assertEqual(admin.rays("extra", [[1, 3, 10]], [[0, 0, -1]]).t[0], 8.0)
            admin.unload("extra")
        with self.assertRaises(trioct.NoReply):
            self.c.rays("extra", [[1, 3, 10]], [[0, 0, -1]], timeout_ms=300)

    def test_example(self):
        """python/examples/rays.py, run as a user would, against the box from above its middle."""
        out = subprocess.run([sys.executable, os.path.join(REPO, "python", "examples", "rays.py"), "--url", URL,
                              "--world", "box", "--origin", "2", "1", "10", "--rays", "3"],
                             capture_output=True, text=True, timeout=30)
        self.assertEqual(out.returncode, 0, out.stderr)
        lines = out.stdout.splitlines()
        self.assertEqual(lines[0], "4 rays from (2 1 10) at box: 1 hit")
        self.assertRegex(lines[2], r"^  \+0 deg +t = +8\.0000  point \( +2\.000 +1\.000 +2\.000\)  "
                                   r"normal \( *0\.000 +0\.000 +1\.000\)  box triangle 0$")
        self.assertEqual([l.split()[-1] for l in (lines[1], lines[3], lines[4])], ["miss"] * 3)

    def test_connect_follows_lcm_default_url(self):
        old = os.environ.get("LCM_DEFAULT_URL")
        os.environ["LCM_DEFAULT_URL"] = URL
        try:
            with trioct.connect() as c:
                self.assertEqual(c.url, URL)
                self.assertEqual(c.prefix, "TRIOCT")
                self.assertEqual(c.rays("box", [1, 3, 10], [0, 0, -1]).t[0], 8.0)
        finally:
            if old is None:
                del os.environ["LCM_DEFAULT_URL"]
            else:
                os.environ["LCM_DEFAULT_URL"] = old


if __name__ == "__main__":
    unittest.main()
