/* Mesh queries with the query shape built into an octree of its own: the world tree and the
 * shape tree (the same fixed-resolution builder, the shape in its local frame) descended
 * together, pose by pose.
 *
 * Invariant: a pair (world node W, shape node S) is on the stack only if the world box of
 * W (its content bounds when the world has its compiled form, else its cube), grown on each
 * axis by g (the pose's rounding bound e, the mode's slack and the rounding of the world
 * box's bounds), may meet the image R S + t of S's local box, i.e. no separating axis
 * among the six tested (the world's and the pose's; TESTED_AXES) proves them apart by more
 * than the test's own rounding bound. So every pair of leaves that could hold a contact is
 * reached, and a contact is reported exactly when the mode's final test accepts the pair:
 * the answers are octree_mesh's.
 *
 * Why such a pair of leaves is reached. A posed vertex is fl(R p + t), within e of the
 * real R p + t on each axis (e from the pose and the shape's extent, below). A point x of
 * a posed triangle q is the same convex combination of its posed vertices as a point y of
 * q's local triangle is of the local ones, so x lies within e of R y + t. y lies in a
 * shape leaf listing q (membership is exact and closed), and R y + t in the image of that
 * leaf's box and of all its ancestors'. In exact mode a contact point x of q and a world
 * triangle w lies in a world leaf listing w, so in its cube and in the box around w: in
 * the leaf's content bounds; in fast and seed mode, w has a point within the mode's slack
 * of x (octree_modes.c), in such a leaf's. Either way the world leaf's box grown by g meets
 * the shape leaf's image, as do all their ancestors' boxes: no pair on the way is dropped.
 *
 * The separating-axis test is computed in double and rejects a pair only when the
 * computed separation exceeds a bound on its rounding error (pose_frame_make has the
 * derivation), so a pair whose exact boxes touch is never dropped. Poses outside the
 * range of that derivation (huge coordinates or matrix entries) take the per-triangle
 * path instead, which needs no such bound. */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "../geom/lanes4.h"
#include "../geom/predicates.h"
#include "../geom/tri_tri.h"
#include "octree_internal.h"
#include "octree_modes.h"

#define U 0x1p-53
/* Absolute error a subnormal result can add, magnified by factors within the range below
 * (matrix entries up to 2^32, a few dozen operations): far below 2^-900. */
#define UNDERFLOW_PAD 0x1p-900
/* The range the error bounds are derived for: matrix entries up to 2^32, coordinates,
 * translations and slacks up to 2^400, so no product or sum of the test overflows. */
#define POSE_ENTRY_MAX 0x1p32
#define POSE_RANGE_MAX 0x1p400

/* The separating axes tested: the world's three and the pose's three columns (the shape
 * box's edges in the world frame). For a rotation these are six of the box-box axes of
 * the separating-axis theorem (the nine cross products of one of each are the rest,
 * which the descent does not test: a missed separation only keeps a pair); for any other
 * matrix they are still axes, and a separation along any axis is a proof. Every axis is
 * exact: a column is three matrix entries. Only these six are built, once a pose. */
#define TESTED_AXES 6
enum { AXES = TESTED_AXES };

typedef struct pose_frame {
    const pose *at;
    double axis[AXES][3];
    double axis_abs[AXES][3];
    /* reach[a][i] >= |axis_a . column_i|: the shape box's half side i projects to
     * reach[a][i] times it. */
    double reach[AXES][3];
    double margin[AXES];  /* the rounding bound of the test along each axis */
    double widen[3];      /* g: e plus the mode's slack, per world axis */
    double grow;          /* the mode's slack (0 in exact mode) */
    double content_pad;   /* grow plus the rounding of a world box's bounds */
    double scale;         /* how much the pose stretches a shape length, for the split choice */
} pose_frame;

static double max_abs3(double a, double b, double c) { return fmax(fabs(a), fmax(fabs(b), fabs(c))); }

/* The frame of one pose, or 0 when the pose or the trees are outside the range of the
 * error bounds below (the caller then takes the per-triangle path).
 *
 * Error bounds, u = 2^-53, all quantities within the range above. Let M_s[i] be the
 * largest |coordinate i| of the shape's cube (every local vertex and node centre is
 * inside it), M_w the largest |coordinate| of the world's cube, and
 *   T_k = sum_i |R_ki| M_s[i] + |t_k|.
 * Posed vertex: fl(R p + t)_k is a four-term sum of three products and t_k, evaluated left
 * to right: off by at most gamma_4 T_k < 4.01u T_k; e_k = 5u T_k + pad.
 * Per pair, the centres cs = fl(0.5 fl(lo + hi)) and cw are off by u |cs| and u |cw|, the
 * halves hs, hw by u of themselves; C = fl(R cs + t) is off from the real R cs* + t by
 * gamma_4 T_k + u T_k, and D = fl(C - cw) from the real D* by
 *   u (T_k + M_w) + 5.01u T_k + u M_w < 7u (T_k + M_w).
 * The projection p = fl(L . D) (at most three terms, L exact) is then off from L . D* by
 * gamma_3 sum |L_k| |D_k| + sum |L_k| 7u (T_k + M_w) < 10.1u sum |L_k| (T_k + M_w).
 * The radius r = fl(sum_k |L_k| (hw_k + g_k) + sum_i reach_i hs_i), six nonnegative
 * products summed, with inputs off by u and reach an upper bound, is below the real
 * radius less 9u r, and r is at most R_max, the same sum over the roots' halves. The
 * comparison |p| > fl(r + m) loses u (r + m). So with
 *   m = 16u (sum_k |L_k| (T_k + M_w) + R_max) + pad
 * (computing m itself rounds by a few u of m, which 16 against 10.1 and 9 covers),
 * |p| > fl(r + m) proves |L . D*| exceeds the real radius: the exact sets are apart. */
/* The longest side of b, by comparisons (the descent's split choice asks at every pop, and
 * libm's fmax is a call); b is finite wherever it is asked. */
static inline double box_extent(box3 b)
{
    double x = b.hi.x - b.lo.x, y = b.hi.y - b.lo.y, z = b.hi.z - b.lo.z, m = x > y ? x : y;
    return m > z ? m : z;
}

static int pose_frame_make(pose_frame *f, const octree *world, const octree *shape, const pose *at, double grow)
{
    const double *r = at->r;
    for (int k = 0; k < 9; k++)
        if (!(fabs(r[k]) <= POSE_ENTRY_MAX))
            return 0;
    double t[3] = {at->t.x, at->t.y, at->t.z};
    box3 sw = shape->world, ww = world->world;
    double ms[3] = {fmax(fabs(sw.lo.x), fabs(sw.hi.x)), fmax(fabs(sw.lo.y), fabs(sw.hi.y)),
                    fmax(fabs(sw.lo.z), fabs(sw.hi.z))};
    /* M_w bounds every world box coordinate the test sees: the cube's, and the compiled
     * form's content bounds, which overshoot the cube by less than a side (a node frame's
     * step is below a hundredth of the cube's side, octree_traversal.c). */
    double side = box_extent(ww);
    double mw = fmax(max_abs3(ww.lo.x, ww.lo.y, ww.lo.z), max_abs3(ww.hi.x, ww.hi.y, ww.hi.z)) + 2 * side;
    if (!(max_abs3(ms[0], ms[1], ms[2]) <= POSE_RANGE_MAX) || !(mw <= POSE_RANGE_MAX) ||
        !(max_abs3(t[0], t[1], t[2]) <= POSE_RANGE_MAX) || !(grow >= 0.0 && grow <= POSE_RANGE_MAX))
        return 0;
    f->at = at;
    f->grow = grow;
    /* A content bound of the compiled form, world.lo + offset, rounds once (by u M_w), and
     * growing it rounds again: 4u M_w covers both. */
    f->content_pad = grow + 4 * U * mw + UNDERFLOW_PAD;
    double tk[3];
    for (int k = 0; k < 3; k++) {
        tk[k] = fabs(r[3 * k]) * ms[0] + fabs(r[3 * k + 1]) * ms[1] + fabs(r[3 * k + 2]) * ms[2] + fabs(t[k]);
        f->widen[k] = 5 * U * tk[k] + UNDERFLOW_PAD + f->content_pad;
    }
    double col[3][3];
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            col[i][k] = r[3 * k + i];
    int a = 0;
    for (int k = 0; k < 3; k++, a++)
        for (int j = 0; j < 3; j++)
            f->axis[a][j] = j == k;
    for (int i = 0; i < 3; i++, a++)
        for (int j = 0; j < 3; j++)
            f->axis[a][j] = col[i][j];
    double hw[3] = {0.5 * (ww.hi.x - ww.lo.x), 0.5 * (ww.hi.y - ww.lo.y), 0.5 * (ww.hi.z - ww.lo.z)};
    double hs[3] = {0.5 * (sw.hi.x - sw.lo.x), 0.5 * (sw.hi.y - sw.lo.y), 0.5 * (sw.hi.z - sw.lo.z)};
    for (a = 0; a < AXES; a++) {
        const double *l = f->axis[a];
        double span = 0.0, radius = 0.0;
        for (int k = 0; k < 3; k++) {
            f->axis_abs[a][k] = fabs(l[k]);
            span += fabs(l[k]) * (tk[k] + mw);
            radius += fabs(l[k]) * (hw[k] + f->widen[k]);
        }
        for (int i = 0; i < 3; i++) {
            const double *c = col[i];
            double dot = l[0] * c[0] + l[1] * c[1] + l[2] * c[2];
            double abs_sum = fabs(l[0] * c[0]) + fabs(l[1] * c[1]) + fabs(l[2] * c[2]);
            /* gamma_3 abs_sum bounds the dot's rounding; 8u covers it and this sum's own. */
            f->reach[a][i] = fabs(dot) + 8 * U * abs_sum + UNDERFLOW_PAD;
            radius += f->reach[a][i] * hs[i];
        }
        f->margin[a] = 16 * U * (span + radius) + UNDERFLOW_PAD;
        if (!isfinite(f->margin[a]))
            return 0;
    }
    double scale = 0.0;
    for (int i = 0; i < 3; i++)
        scale = fmax(scale, max_abs3(col[i][0], col[i][1], col[i][2]));
    f->scale = scale;
    return 1;
}

/* The test splits in two sides, so that an expansion computes the side of the node it
 * keeps once for its eight children. Along axis a, a box's side is the projection of its
 * centre, fl(L_a . centre) (for the world's axes the coordinate itself), and its radius;
 * the world box's radius includes g. Two boxes are apart along a when
 *   |fl(p_shape - p_world)| > fl(fl(r_shape + r_world) + m_a).
 * Rounding, with the bounds of pose_frame_make: the posed centre C is off by 5.01u T_k,
 * the world centre by u M_w; the two projections round by gamma_3 of their terms' sums
 * and their difference by u of its operands, in all at most
 *   (5.01 + 3.02 + 1) u sum |L_k| T_k + (1 + 3.01 + 1) u sum |L_k| M_w < 9.1u span,
 * and the radii are each a sum of three nonnegative products over inputs off by u, plus
 * one addition: 9u of the radius, below m_a's share. */
typedef struct box_side {
    double p[AXES], r[AXES];
} box_side;

/* A shape box's posed centre c and its local half sides hs: the centre posed as
 * octree_apply_pose poses a vertex (the bounds assume this order). */
static inline __attribute__((always_inline)) void shape_box_posed(const pose_frame *f, box3 sb, double c[3],
                                                                 double hs[3])
{
    const double *r = f->at->r;
    double cs[3] = {0.5 * (sb.lo.x + sb.hi.x), 0.5 * (sb.lo.y + sb.hi.y), 0.5 * (sb.lo.z + sb.hi.z)};
    hs[0] = 0.5 * (sb.hi.x - sb.lo.x);
    hs[1] = 0.5 * (sb.hi.y - sb.lo.y);
    hs[2] = 0.5 * (sb.hi.z - sb.lo.z);
    c[0] = r[0] * cs[0] + r[1] * cs[1] + r[2] * cs[2] + f->at->t.x;
    c[1] = r[3] * cs[0] + r[4] * cs[1] + r[5] * cs[2] + f->at->t.y;
    c[2] = r[6] * cs[0] + r[7] * cs[1] + r[8] * cs[2] + f->at->t.z;
}

static inline void shape_side_of(const pose_frame *f, box3 sb, box_side *s)
{
    double c[3], hs[3];
    shape_box_posed(f, sb, c, hs);
    for (int a = 0; a < TESTED_AXES; a++) {
        const double *l = f->axis[a], *q = f->reach[a];
        s->p[a] = a < 3 ? c[a] : l[0] * c[0] + l[1] * c[1] + l[2] * c[2];
        s->r[a] = q[0] * hs[0] + q[1] * hs[1] + q[2] * hs[2];
    }
}

static inline void world_side_of(const pose_frame *f, box3 wb, box_side *w)
{
    double c[3] = {0.5 * (wb.lo.x + wb.hi.x), 0.5 * (wb.lo.y + wb.hi.y), 0.5 * (wb.lo.z + wb.hi.z)};
    double h[3] = {0.5 * (wb.hi.x - wb.lo.x) + f->widen[0], 0.5 * (wb.hi.y - wb.lo.y) + f->widen[1],
                   0.5 * (wb.hi.z - wb.lo.z) + f->widen[2]};
    for (int a = 0; a < TESTED_AXES; a++) {
        const double *l = f->axis[a], *la = f->axis_abs[a];
        w->p[a] = a < 3 ? c[a] : l[0] * c[0] + l[1] * c[1] + l[2] * c[2];
        w->r[a] = la[0] * h[0] + la[1] * h[1] + la[2] * h[2];
    }
}

/* A world box against a shape box's side, the world's side computed axis by axis so that
 * the first separating axis ends the test (the same values world_side_of computes). */
static inline int world_box_apart(const pose_frame *f, box3 wb, const box_side *s)
{
    double c[3] = {0.5 * (wb.lo.x + wb.hi.x), 0.5 * (wb.lo.y + wb.hi.y), 0.5 * (wb.lo.z + wb.hi.z)};
    double h[3] = {0.5 * (wb.hi.x - wb.lo.x) + f->widen[0], 0.5 * (wb.hi.y - wb.lo.y) + f->widen[1],
                   0.5 * (wb.hi.z - wb.lo.z) + f->widen[2]};
    for (int k = 0; k < 3; k++)
        if (fabs(s->p[k] - c[k]) > s->r[k] + h[k] + f->margin[k])
            return 1;
    for (int a = 3; a < TESTED_AXES; a++) {
        const double *l = f->axis[a], *la = f->axis_abs[a];
        double p = l[0] * c[0] + l[1] * c[1] + l[2] * c[2];
        double r = la[0] * h[0] + la[1] * h[1] + la[2] * h[2];
        if (fabs(s->p[a] - p) > s->r[a] + r + f->margin[a])
            return 1;
    }
    return 0;
}

static inline box3 box_grown(box3 b, double g)
{
    return (box3){vec3_sub(b.lo, (vec3){g, g, g}), vec3_add(b.hi, (vec3){g, g, g})};
}

/* ---------- the children of one expansion, side by side ----------
 *
 * An expansion tests up to eight children against the node it keeps: world children by
 * world_box_apart, shape children by the shape side of the same test (shape_side_of's
 * projection and radius against the world node's side). Four children go to a vector
 * (lanes4.h), every operation in the order of the one-child expressions above, so each
 * lane rounds exactly as they do and the bounds derived for them hold lane by lane;
 * world_box_apart's early exit at the first separating axis is gone, which changes no
 * answer. Each returns the mask of the children that may meet (bit k for child k); the
 * caller drops empty ones. */
#define LANES_INLINE static inline __attribute__((always_inline))

/* The children's boxes, coordinate by coordinate. */
typedef struct child_boxes {
    double lo[3][8], hi[3][8];
} child_boxes;

/* The compiled node's eight content bounds: origin + q scale is exact (octree_traversal.h),
 * the sum with the world's corner rounds once. */
LANES_INLINE void lanes_of_form_axis(const traversal_node *n, int a, double o, child_boxes *b)
{
    double sc = n->scale, base = n->origin[a];
    const uint8_t *lo = n->q[TRAVERSAL_LO_X + a], *hi = n->q[TRAVERSAL_HI_X + a];
    STORE4(&b->lo[a][0], o + (base + BYTES4(lo) * sc));
    STORE4(&b->lo[a][4], o + (base + BYTES4(lo + 4) * sc));
    STORE4(&b->hi[a][0], o + (base + BYTES4(hi) * sc));
    STORE4(&b->hi[a][4], o + (base + BYTES4(hi + 4) * sc));
}

LANES_INLINE void lanes_of_form(const octree *world, const traversal_node *n, child_boxes *b)
{
    lanes_of_form_axis(n, 0, world->world.lo.x, b);
    lanes_of_form_axis(n, 1, world->world.lo.y, b);
    lanes_of_form_axis(n, 2, world->world.lo.z, b);
}

/* world_box_apart of children h..h+3 against s. */
LANES_INLINE unsigned world_lanes_apart(const pose_frame *f, const child_boxes *b, int h, const box_side *s)
{
    lanes4 c[3], w[3];
    for (int a = 0; a < 3; a++) {
        lanes4 lo = LOAD4(&b->lo[a][h]), hi = LOAD4(&b->hi[a][h]);
        c[a] = 0.5 * (lo + hi);
        w[a] = 0.5 * (hi - lo) + f->widen[a];
    }
    mask4 apart = (ABS4(s->p[0] - c[0]) > s->r[0] + w[0] + f->margin[0]) |
                  (ABS4(s->p[1] - c[1]) > s->r[1] + w[1] + f->margin[1]) |
                  (ABS4(s->p[2] - c[2]) > s->r[2] + w[2] + f->margin[2]);
    /* The world's axes alone most often settle all four: the shape's then change nothing. */
    if (BITS4(apart) == 0xfu)
        return 0xfu;
    for (int a = 3; a < TESTED_AXES; a++) {
        const double *l = f->axis[a], *la = f->axis_abs[a];
        lanes4 p = l[0] * c[0] + l[1] * c[1] + l[2] * c[2];
        lanes4 r = la[0] * w[0] + la[1] * w[1] + la[2] * w[2];
        apart |= ABS4(s->p[a] - p) > s->r[a] + r + f->margin[a];
    }
    return BITS4(apart);
}

/* Shape children h..h+3 of g (their bounds' centres and half sides), posed, against the
 * world node's side w: shape_side_of's projection and radius of each, compared as
 * world_box_apart compares. */
LANES_INLINE unsigned shape_lanes_apart(const pose_frame *f, const child_lanes *g, int h, const box_side *w)
{
    lanes4 cs[3] = {LOAD4(&g->c[0][h]), LOAD4(&g->c[1][h]), LOAD4(&g->c[2][h])};
    lanes4 hs[3] = {LOAD4(&g->h[0][h]), LOAD4(&g->h[1][h]), LOAD4(&g->h[2][h])};
    const double *r = f->at->r;
    /* The centre posed as octree_apply_pose poses a vertex, as in shape_side_of. */
    lanes4 c[3] = {r[0] * cs[0] + r[1] * cs[1] + r[2] * cs[2] + f->at->t.x,
                   r[3] * cs[0] + r[4] * cs[1] + r[5] * cs[2] + f->at->t.y,
                   r[6] * cs[0] + r[7] * cs[1] + r[8] * cs[2] + f->at->t.z};
    mask4 apart = {0, 0, 0, 0};
    for (int a = 0; a < TESTED_AXES; a++) {
        const double *l = f->axis[a], *q = f->reach[a];
        lanes4 p = a < 3 ? c[a] : l[0] * c[0] + l[1] * c[1] + l[2] * c[2];
        lanes4 rs = q[0] * hs[0] + q[1] * hs[1] + q[2] * hs[2];
        apart |= ABS4(p - w->p[a]) > rs + w->r[a] + f->margin[a];
        if (a == 2 && BITS4(apart) == 0xfu) /* as in world_lanes_apart */
            return 0xfu;
    }
    return BITS4(apart);
}

/* A world expansion: children whose boxes (left in b for the pushes) may meet the shape
 * node's side s. */
LANES_INLINE unsigned world_lanes_near(const pose_frame *f, const child_boxes *b, const box_side *s, unsigned live)
{
    unsigned near = 0;
    for (int h = 0; h < 8; h += 4)
        if (live >> h & 0xfu)
            near |= (~world_lanes_apart(f, b, h, s) & 0xfu) << h;
    return near & live;
}

/* One expansion's child tests (the lanes above): a compiled world node's children, eight
 * world cells, or eight shape boxes against the world node's side w. Each is compiled
 * twice, for the baseline and for AVX2, and lane_tests_here picks one set per call. */
LANES_INLINE unsigned form_children_near(const pose_frame *f, const octree *world, const traversal_node *n,
                                         const box_side *s, unsigned live, child_boxes *b)
{
    lanes_of_form(world, n, b);
    return world_lanes_near(f, b, s, live);
}

LANES_INLINE unsigned world_children_near(const pose_frame *f, const box3 cells[8], const box_side *s,
                                          unsigned live, child_boxes *b)
{
    for (int k = 0; k < 8; k++) {
        b->lo[0][k] = cells[k].lo.x, b->lo[1][k] = cells[k].lo.y, b->lo[2][k] = cells[k].lo.z;
        b->hi[0][k] = cells[k].hi.x, b->hi[1][k] = cells[k].hi.y, b->hi[2][k] = cells[k].hi.z;
    }
    return world_lanes_near(f, b, s, live);
}

LANES_INLINE unsigned shape_children_near(const pose_frame *f, const child_lanes *g, const box_side *w, unsigned live)
{
    unsigned near = 0;
    for (int h = 0; h < 8; h += 4)
        if (live >> h & 0xfu)
            near |= (~shape_lanes_apart(f, g, h, w) & 0xfu) << h;
    return near & live;
}

typedef struct lane_tests {
    unsigned (*form)(const pose_frame *, const octree *, const traversal_node *, const box_side *, unsigned,
                     child_boxes *);
    unsigned (*world)(const pose_frame *, const box3 *, const box_side *, unsigned, child_boxes *);
    unsigned (*shape)(const pose_frame *, const child_lanes *, const box_side *, unsigned);
} lane_tests;

#define LANE_TESTS(suffix, attr)                                                                                  \
    attr static unsigned form_children_##suffix(const pose_frame *f, const octree *world, const traversal_node *n, \
                                                const box_side *s, unsigned live, child_boxes *b)                \
    {                                                                                                             \
        return form_children_near(f, world, n, s, live, b);                                                       \
    }                                                                                                             \
    attr static unsigned world_children_##suffix(const pose_frame *f, const box3 *cells, const box_side *s,        \
                                                 unsigned live, child_boxes *b)                                  \
    {                                                                                                             \
        return world_children_near(f, cells, s, live, b);                                                         \
    }                                                                                                             \
    attr static unsigned shape_children_##suffix(const pose_frame *f, const child_lanes *g, const box_side *w,     \
                                                 unsigned live)                                                   \
    {                                                                                                             \
        return shape_children_near(f, g, w, live);                                                                \
    }

LANE_TESTS(portable, )
#if defined(__x86_64__) || defined(__i386__)
LANE_TESTS(avx2, __attribute__((target("avx2"))))
#endif

static int lanes_portable_forced;

void octree_shape_lanes_force_portable(int on) { lanes_portable_forced = on; }

static lane_tests lane_tests_here(void)
{
#if defined(__x86_64__) || defined(__i386__)
    static int avx2 = -1; /* a benign race: every thread stores the same answer */
    if (avx2 < 0)
        avx2 = __builtin_cpu_supports("avx2") ? 1 : 0;
    if (avx2 && !lanes_portable_forced)
        return (lane_tests){form_children_avx2, world_children_avx2, shape_children_avx2};
#endif
    return (lane_tests){form_children_portable, world_children_portable, shape_children_portable};
}

/* What a shape node's image is tested with: the bounds of its triangles within its box
 * when the tree has them (octree_def.node_bounds), else the box itself. Either holds every
 * local point of the node's triangles that lies in the node. */
static inline box3 shape_node_box(const octree *shape, uint32_t node, box3 cell)
{
    return shape->node_bounds ? shape->node_bounds[node] : cell;
}

/* ---------- per-call scratch ---------- */

/* A shape vertex under the current pose, and (exact mode, a world with triangle boxes)
 * its outward float box relative to the world's corner. The rounding is monotonic, so the
 * union of a triangle's vertices' float boxes is the triangle's own outward box. */
typedef struct posed_vertex {
    vec3 v;
    triangle_box box;
} posed_vertex;

/* A shape triangle under the current pose: its posed vertices and bounds, computed when a
 * leaf first needs them, and (exact mode) the query side of the exact test, computed when
 * the triangle is first tested. */
typedef struct posed_triangle {
    tri_tri_query query; /* v and box always; plane, axis and turn once prepared */
    triangle_box box;    /* outward float box against the world's triangle boxes */
} posed_triangle;

/* Internal (shape, world) id pairs tested under the current pose: a triangle sits in
 * several leaves, so the same pair can meet in several leaf pairs. A slot holds a key of
 * the current pose only when its stamp is the set's epoch, so starting a pose clears
 * nothing: most poses test a few dozen pairs, and wiping the table cost more than that. */
#define PAIR_SET_INLINE 256

typedef struct pair_set {
    uint64_t *keys;
    uint32_t *stamps;
    size_t mask, count;
    uint32_t epoch;
    uint64_t inline_keys[PAIR_SET_INLINE];
    uint32_t inline_stamps[PAIR_SET_INLINE];
} pair_set;

typedef struct pair_entry {
    uint32_t world_node, shape_node;
    box3 world_box, shape_box;
} pair_entry;

/* A node's side, kept for the rest of a descent: a node's box is the same in every pair it
 * is in (a shape node's cell or bounds, a world node's cube or the content bounds its one
 * parent records), and its pairs come in runs, depth first, so the side of a node expanded
 * against one node of the other tree is mostly wanted again for its next. */
#define SIDE_SLOTS 64
typedef struct side_slot {
    uint32_t stamp, node;
    box_side side;
} side_slot;

/* Node's slot among slots; *fresh is 1 when it held another node or an earlier descent's
 * side, and the slot is then claimed for node: the caller makes its side. */
static inline side_slot *side_slot_of(side_slot slots[SIDE_SLOTS], uint32_t node, uint32_t epoch, int *fresh)
{
    side_slot *slot = &slots[node % SIDE_SLOTS];
    *fresh = slot->stamp != epoch || slot->node != node;
    slot->stamp = epoch;
    slot->node = node;
    return slot;
}

typedef struct shape_scratch {
    const octree *world, *shape;
    accuracy_mode mode;
    /* Exact mode over a world with triangle boxes: the float boxes filter pairs (posed
     * vertices get one, leaf pairs and shape nodes under a world leaf test against them). */
    int boxed;
    uint32_t epoch; /* the current pose's stamp */
    /* Per shape triangle (allocated on first need): posed[q] holds the current pose when
     * posed_stamp[q] == epoch, and its exact query side when prepared_stamp[q] == epoch. */
    posed_triangle *posed;
    uint32_t *posed_stamp, *prepared_stamp;
    /* Per shape vertex: posed_vertices[v] holds the current pose when vertex_stamp[v] ==
     * epoch. A vertex is shared by about six triangles, so it is posed once, not six
     * times. */
    struct posed_vertex *posed_vertices;
    uint32_t *vertex_stamp;
    pair_entry *stack;
    /* Sides made in the current descent (stamp == side_epoch), direct-mapped by node: a
     * shape node's for world expansions, a world node's for shape expansions. */
    uint32_t side_epoch;
    side_slot shape_sides[SIDE_SLOTS], world_sides[SIDE_SLOTS];
    pair_set tested;
    uint64_t *hits; /* (caller's shape id << 32 | caller's world id) */
    size_t hit_count, hit_capacity;
    /* A world tree placed by a pose (octree_mesh_tree_posed), else NULL: the descent runs
     * in the world tree's frame with the shape at its relative pose, and each pair is
     * tested in the world, the shape triangle posed at shape_at (kept in world_posed[q]
     * when world_stamp[q] == epoch) and the world triangle at world_at. */
    const pose *world_at, *shape_at;
    tri_tri_query *world_posed;
    uint32_t *world_stamp;
    size_t stack_cap; /* entries the stack holds */
} shape_scratch;

static void pair_set_clear(pair_set *s)
{
    if (++s->epoch == 0) {
        memset(s->stamps, 0, (s->mask + 1) * sizeof *s->stamps);
        s->epoch = 1;
    }
    s->count = 0;
}

static void pair_set_init(pair_set *s)
{
    s->keys = s->inline_keys;
    s->stamps = s->inline_stamps;
    s->mask = PAIR_SET_INLINE - 1;
    s->count = 0;
    s->epoch = 1;
    memset(s->stamps, 0, sizeof s->inline_stamps);
}

static void pair_set_free(pair_set *s)
{
    if (s->keys != s->inline_keys) {
        free(s->keys);
        free(s->stamps);
    }
}

static size_t pair_slot(uint64_t key, size_t mask) { return (size_t)((key * 0x9E3779B97F4A7C15ull) >> 40) & mask; }

static int pair_set_grow(pair_set *s)
{
    size_t cap = 2 * (s->mask + 1);
    uint64_t *keys = malloc(cap * sizeof *keys);
    uint32_t *stamps = calloc(cap, sizeof *stamps);
    if (!keys || !stamps) {
        free(keys);
        free(stamps);
        return -1;
    }
    for (size_t i = 0; i <= s->mask; i++) {
        if (s->stamps[i] != s->epoch)
            continue;
        size_t k = pair_slot(s->keys[i], cap - 1);
        while (stamps[k] == s->epoch)
            k = (k + 1) & (cap - 1);
        keys[k] = s->keys[i];
        stamps[k] = s->epoch;
    }
    pair_set_free(s);
    s->keys = keys;
    s->stamps = stamps;
    s->mask = cap - 1;
    return 0;
}

/* 1 when added, 0 when there already, -1 when memory ran out. */
static inline int pair_set_insert(pair_set *s, uint64_t key)
{
    size_t k = pair_slot(key, s->mask);
    for (;;) {
        if (s->stamps[k] != s->epoch)
            break;
        if (s->keys[k] == key)
            return 0;
        k = (k + 1) & s->mask;
    }
    if (2 * (s->count + 1) > s->mask + 1) {
        if (pair_set_grow(s) != 0)
            return -1;
        k = pair_slot(key, s->mask);
        while (s->stamps[k] == s->epoch)
            k = (k + 1) & s->mask;
    }
    s->keys[k] = key;
    s->stamps[k] = s->epoch;
    s->count++;
    return 1;
}

/* Stack entries: each pop pushes at most 8, and each push goes one level down one tree. */
static size_t stack_capacity(const octree *world, const octree *shape)
{
    return 8 * ((size_t)world->info.max_level + (size_t)shape->info.max_level + 2) + 1;
}

static shape_scratch *scratch_new(const octree *world, const octree *shape, accuracy_mode mode)
{
    shape_scratch *s = malloc(sizeof *s);
    if (!s)
        return NULL;
    memset(s, 0, offsetof(shape_scratch, tested));
    s->world = world;
    s->shape = shape;
    s->mode = mode;
    s->boxed = mode == ACCURACY_EXACT && world->triangle_boxes;
    s->world_at = s->shape_at = NULL;
    s->world_posed = NULL;
    s->world_stamp = NULL;
    s->hits = NULL;
    s->hit_count = s->hit_capacity = 0;
    pair_set_init(&s->tested);
    s->stack_cap = stack_capacity(world, shape);
    s->stack = malloc(s->stack_cap * sizeof *s->stack);
    if (!s->stack) {
        free(s);
        return NULL;
    }
    return s;
}

static void scratch_free(shape_scratch *s)
{
    if (!s)
        return;
    pair_set_free(&s->tested);
    free(s->posed);
    free(s->posed_stamp);
    free(s->posed_vertices);
    free(s->world_posed);
    free(s->world_stamp);
    free(s->stack);
    free(s->hits);
    free(s);
}

/* The per-triangle and per-vertex arrays, on the first pose that reaches a leaf pair; the
 * stamps in one zeroed block. */
static int scratch_arrays(shape_scratch *s)
{
    if (s->posed)
        return 0;
    size_t n = s->shape->triangle_count, verts = s->shape->used_vertex_count;
    s->posed = malloc(n * sizeof *s->posed);
    s->posed_vertices = malloc(verts * sizeof *s->posed_vertices);
    s->posed_stamp = calloc(2 * n + verts, sizeof *s->posed_stamp);
    if (s->world_at) {
        s->world_posed = malloc(n * sizeof *s->world_posed);
        s->world_stamp = calloc(n, sizeof *s->world_stamp);
    }
    if (s->posed && s->posed_vertices && s->posed_stamp && (!s->world_at || (s->world_posed && s->world_stamp))) {
        s->prepared_stamp = s->posed_stamp + n;
        s->vertex_stamp = s->prepared_stamp + n;
        return 0;
    }
    free(s->world_posed);
    free(s->world_stamp);
    s->world_posed = NULL;
    s->world_stamp = NULL;
    free(s->posed);
    free(s->posed_vertices);
    free(s->posed_stamp);
    s->posed = NULL;
    return -1;
}

/* Starts a pose: no shape triangle is posed yet, no pair tested, no hit. */
static void scratch_next_pose(shape_scratch *s)
{
    if (++s->epoch == 0) {
        if (s->posed)
            memset(s->posed_stamp, 0,
                   (2 * s->shape->triangle_count + s->shape->used_vertex_count) *
                       sizeof *s->posed_stamp);
        if (s->world_stamp)
            memset(s->world_stamp, 0, s->shape->triangle_count * sizeof *s->world_stamp);
        s->epoch = 1;
    }
    pair_set_clear(&s->tested);
    s->hit_count = 0;
}

/* Shape triangle q under the pose (scratch_arrays done). */
static posed_triangle *posed_get(shape_scratch *s, const pose *at, uint32_t q)
{
    posed_triangle *p = &s->posed[q];
    if (s->posed_stamp[q] == s->epoch)
        return p;
    s->posed_stamp[q] = s->epoch;
    const uint32_t *corner = s->shape->corners[q];
    const posed_vertex *pv[3];
    for (int k = 0; k < 3; k++) {
        uint32_t i = corner[k];
        posed_vertex *x = &s->posed_vertices[i];
        if (s->vertex_stamp[i] != s->epoch) {
            s->vertex_stamp[i] = s->epoch;
            x->v = octree_apply_pose(at, s->shape->vertices[i]);
            if (s->boxed) {
                x->box = triangle_box_of_point(x->v, s->world->world.lo);
            }
        }
        pv[k] = x;
        p->query.v[k] = x->v;
    }
    vec3 *v = p->query.v;
    p->query.box = (box3){vec3_min(vec3_min(v[0], v[1]), v[2]), vec3_max(vec3_max(v[0], v[1]), v[2])};
    if (s->boxed) {
        p->box = pv[0]->box;
        triangle_box_add(&p->box, &pv[1]->box);
        triangle_box_add(&p->box, &pv[2]->box);
    }
    return p;
}

/* ---------- candidate pairs ---------- */

typedef struct pose_query {
    shape_scratch *s;
    const pose *at;
    const pose_frame *frame; /* set by descend */
    int all_pairs;
    int any;
    uint64_t first; /* the first contact found (caller's shape id << 32 | world id) */
    octree_status status;
    query_stats *stats;
} pose_query;

/* Tests shape triangle q (posed) against world triangle w once per pose, records a
 * contact; 1 when the query is over (its first contact for yes/no, or out of memory). */
static int test_fresh_pair(pose_query *pq, posed_triangle *p, uint32_t q, uint32_t w);

static inline __attribute__((always_inline)) int take_pair(pose_query *pq, posed_triangle *p, uint32_t q,
                                                          uint32_t w)
{
    /* Inlined: most pairs met were met before in another leaf pair (two of three on a
     * collision-free Spider pose), and end here. */
    int fresh = pair_set_insert(&pq->s->tested, (uint64_t)q << 32 | w);
    if (fresh == 0)
        return 0;
    if (fresh < 0) {
        pq->status = OCTREE_ERR_NOMEM;
        return 1;
    }
    return test_fresh_pair(pq, p, q, w);
}

/* Shape triangle q posed at shape_at, prepared for the exact test (placed worlds only). */
static const tri_tri_query *world_posed_get(shape_scratch *s, uint32_t q)
{
    tri_tri_query *x = &s->world_posed[q];
    if (s->world_stamp[q] != s->epoch) {
        s->world_stamp[q] = s->epoch;
        vec3 v[3];
        octree_triangle_vertices(s->shape, q, v);
        for (int k = 0; k < 3; k++)
            v[k] = octree_apply_pose(s->shape_at, v[k]);
        tri_tri_query_prepare(x, v);
    }
    return x;
}

static int test_fresh_pair(pose_query *pq, posed_triangle *p, uint32_t q, uint32_t w)
{
    shape_scratch *s = pq->s;
    pq->stats->candidates_tested++;
    vec3 wt[3];
    octree_triangle_vertices(s->world, w, wt);
    int touch;
    if (s->world_at) { /* exact mode, both triangles where they stand in the world */
        for (int k = 0; k < 3; k++)
            wt[k] = octree_apply_pose(s->world_at, wt[k]);
        touch = tri_tri_overlap_exact_query(world_posed_get(s, q), wt);
    } else if (s->mode == ACCURACY_EXACT) {
        if (s->prepared_stamp[q] != s->epoch) {
            vec3 v[3] = {p->query.v[0], p->query.v[1], p->query.v[2]};
            tri_tri_query_prepare(&p->query, v);
            s->prepared_stamp[q] = s->epoch;
        }
        touch = tri_tri_overlap_exact_query(&p->query, wt);
    } else {
        touch = s->mode == ACCURACY_SEED ? tri_tri_overlap_seed(p->query.v, wt, s->world->seed_epsilon)
                                         : tri_tri_overlap_fast(p->query.v, wt);
    }
    if (!touch)
        return 0;
    if (!pq->any)
        pq->first = (uint64_t)s->shape->original_id[q] << 32 | s->world->original_id[w];
    pq->any = 1;
    if (!pq->all_pairs)
        return 1;
    if (array_reserve((void **)&s->hits, &s->hit_capacity, s->hit_count + 1, sizeof *s->hits, 64) != 0) {
        pq->status = OCTREE_ERR_NOMEM;
        return 1;
    }
    s->hits[s->hit_count++] = (uint64_t)s->shape->original_id[q] << 32 | s->world->original_id[w];
    return 0;
}

/* The bounds of a world leaf's triangles within its box: every contact a pair of leaves
 * can hold lies in a world triangle and in the leaf's box, so in these. */
static box3 world_leaf_content(const octree *world, octree_node n, box3 cell)
{
    const uint32_t *items = world->leaf_items + n.first;
    vec3 t[3];
    octree_triangle_vertices(world, items[0], t);
    box3 b = {vec3_min(vec3_min(t[0], t[1]), t[2]), vec3_max(vec3_max(t[0], t[1]), t[2])};
    for (uint32_t i = 1; i < n.count; i++) {
        octree_triangle_vertices(world, items[i], t);
        b.lo = vec3_min(b.lo, vec3_min(vec3_min(t[0], t[1]), t[2]));
        b.hi = vec3_max(b.hi, vec3_max(vec3_max(t[0], t[1]), t[2]));
    }
    return (box3){vec3_max(b.lo, cell.lo), vec3_min(b.hi, cell.hi)};
}

#define NEAR_CHUNK 64

/* The outward float box, relative to the world's corner, of shape box sb posed, along the
 * world's axes: on axis k the centre and radius of shape_side_of (the same expressions),
 * the radius grown by the world side's widening and twice the axis's margin. One margin
 * bounds every rounding the descent's test allows for; the second covers the three
 * roundings here (the radius sum, the centre -+ it, and less the corner), each below
 * u (|centre| + radius + M_w), which the margin's 16u of the span and the roots' radius
 * exceeds, so only the conversion to float needs rounding outward (loosely: this box only
 * filters). */
static inline __attribute__((always_inline)) triangle_box shape_reach_box(const pose_frame *f, box3 sb, vec3 corner)
{
    double c[3], hs[3];
    shape_box_posed(f, sb, c, hs);
    double o[3] = {corner.x, corner.y, corner.z};
    triangle_box b;
    for (int k = 0; k < 3; k++) {
        const double *q = f->reach[k];
        double e = q[0] * hs[0] + q[1] * hs[1] + q[2] * hs[2] + 2 * f->margin[k] + f->widen[k];
        b.lo[k] = float_below_loosely((c[k] - e) - o[k]);
        b.hi[k] = float_above_loosely((c[k] + e) - o[k]);
    }
    return b;
}

/* A double at or below (above) the exact value that x, a sum of two doubles, rounded: that
 * sum is within |x| 2^-53 of x, and x less |x| 2^-51 stays below it after its own
 * rounding. An infinity or NaN becomes NaN, which no plane filter decides. */
static inline double double_below(double x) { return x - (fabs(x) * 0x1p-51 + 0x1p-1074); }
static inline double double_above(double x) { return x + (fabs(x) * 0x1p-51 + 0x1p-1074); }

/* What a world triangle is tested against for a shape node under a pose: the node's reach
 * box (shape_reach_box), laid out for the box test, and its corners in doubles (each sum
 * with the world's corner rounded outward) for the plane test. Every contact of a pair
 * below the node lies in that box. */
typedef struct shape_reach {
    triangle_box_probe probe;
    double lo[3], hi[3];
} shape_reach;

static inline shape_reach shape_reach_of(const pose_query *pq, uint32_t node, box3 cell)
{
    const octree *world = pq->s->world;
    triangle_box b = shape_reach_box(pq->frame, shape_node_box(pq->s->shape, node, cell), world->world.lo);
    shape_reach r = {.probe = triangle_box_probe_of(&b)};
    for (int k = 0; k < 3; k++) {
        r.lo[k] = double_below(vec3_get(world->world.lo, k) + (double)b.lo[k]);
        r.hi[k] = double_above(vec3_get(world->world.lo, k) + (double)b.hi[k]);
    }
    return r;
}

/* Whether world triangle w may hold a contact within reach r: its outward box meets the
 * box, and its plane does not have the whole box strictly on one side (a contact lies in
 * the box and in the plane). A leaf's triangles' boxes and planes hug a slanted surface far
 * closer than their union's box, the leaf's content, does: on a collision-free pose the
 * plane drops most of the triangles the boxes keep (85% on the peer bench's Spider). */
static inline int world_triangle_near(const octree *world, uint32_t w, const shape_reach *r)
{
    if (triangle_box_probe_apart(&world->triangle_boxes[w], &r->probe))
        return 0;
    vec3 t[3];
    octree_triangle_vertices(world, w, t);
    orient3d_plane plane = orient3d_plane_make(t[0], t[1], t[2]);
    return tri_tri_plane_box_side(&plane, r->lo, r->hi) == 0;
}

/* Whether some triangle of world leaf wn may meet shape node `node` (cell its cell), by
 * world_triangle_near (exact mode, a world with triangle boxes). */
static int world_leaf_near(const pose_query *pq, octree_node wn, uint32_t node, box3 cell)
{
    const octree *world = pq->s->world;
    shape_reach r = shape_reach_of(pq, node, cell);
    const uint32_t *items = world->leaf_items + wn.first;
    for (uint32_t i = 0; i < wn.count; i++)
        if (world_triangle_near(world, items[i], &r))
            return 1;
    return 0;
}

/* A world leaf against a shape leaf; 1 when the query is over. A shape triangle whose
 * bounds miss the world leaf's content (grown by the slack) need not be tested here: a
 * contact lies in some world leaf whose content it meets, and that leaf's pair with the
 * shape leaf is reached too. In exact mode over a world with triangle boxes, the world
 * triangles are first sorted by world_triangle_near against the whole shape leaf, before
 * any of its triangles is posed (most leaf pairs of a pose that touches nothing end
 * there), and then a pair is tested only when the two triangles' outward boxes meet. */
static int leaf_pair(pose_query *pq, octree_node wn, box3 content, uint32_t shape_node, box3 shape_cell)
{
    shape_scratch *s = pq->s;
    const octree *world = s->world;
    octree_node sn = s->shape->nodes[shape_node];
    const uint32_t *shape_items = s->shape->leaf_items + sn.first, *world_items = world->leaf_items + wn.first;
    if (scratch_arrays(s) != 0) {
        pq->status = OCTREE_ERR_NOMEM;
        return 1;
    }
    if (!s->boxed) {
        for (uint32_t i = 0; i < sn.count; i++) {
            uint32_t q = shape_items[i];
            posed_triangle *p = posed_get(s, pq->at, q);
            if (boxes_apart(p->query.box, content))
                continue;
            for (uint32_t j = 0; j < wn.count; j++)
                if (take_pair(pq, p, q, world_items[j]))
                    return 1;
        }
        return 0;
    }
    const triangle_box *boxes = world->triangle_boxes;
    shape_reach reach = shape_reach_of(pq, shape_node, shape_cell);
    uint32_t near[NEAR_CHUNK];
    for (uint32_t start = 0; start < wn.count; start += NEAR_CHUNK) {
        uint32_t end = wn.count - start < NEAR_CHUNK ? wn.count : start + NEAR_CHUNK, m = 0;
        for (uint32_t j = start; j < end; j++) {
            uint32_t w = world_items[j];
            near[m] = w;
            m += world_triangle_near(world, w, &reach);
        }
        if (m == 0)
            continue;
        for (uint32_t i = 0; i < sn.count; i++) {
            uint32_t q = shape_items[i];
            posed_triangle *p = posed_get(s, pq->at, q);
            if (boxes_apart(p->query.box, content))
                continue;
            triangle_box_probe probe = triangle_box_probe_of(&p->box);
            for (uint32_t j = 0; j < m; j++) {
                uint32_t w = near[j];
                if (!triangle_box_probe_apart(&boxes[w], &probe) && take_pair(pq, p, q, w))
                    return 1;
            }
        }
    }
    return 0;
}

static double box_width(box3 b) { return b.hi.x - b.lo.x; }

/* The world side of a pair. With the world's compiled form (octree_traversal.h) a world
 * node is a compiled node or a leaf reference, and its box the content bounds its parent
 * records: the union of its triangles' boxes clipped to its cube, which a surface fills
 * far less than the cube. Every contact point of the node's triangles within its cube lies
 * in them, so they stand in for the cube in every test (widened by the frame's content_pad
 * for the rounding of world.lo + offset). Without the form a world node is an octree node
 * and its box its cube. */
static inline int world_is_leaf(const octree *world, int form, uint32_t ref)
{
    return form ? (ref & TRAVERSAL_LEAF) != 0 : world->nodes[ref].count != NODE_INTERIOR;
}

static inline octree_node world_leaf_of(const octree *world, int form, uint32_t ref)
{
    return form ? octree_leaf_of_ref(world, ref) : world->nodes[ref];
}

/* A world leaf's content: with the form its box already is; else computed from its
 * triangles. */
static inline box3 world_leaf_box(const octree *world, int form, octree_node n, box3 b)
{
    return form ? b : world_leaf_content(world, n, b);
}

static inline box3 lane_of(const child_boxes *b, int k)
{
    return (box3){{b->lo[0][k], b->lo[1][k], b->lo[2][k]}, {b->hi[0][k], b->hi[1][k], b->hi[2][k]}};
}

/* The lanes of a compiled node that hold a child: two compares of four references (the
 * loop over eight cost an expansion a seventh of its instructions). */
static inline unsigned form_live_lanes(const uint32_t child[8])
{
#if defined(__SSE2__)
    __m128i none = _mm_set1_epi32(-1);
    __m128i lo = _mm_cmpeq_epi32(_mm_loadu_si128((const __m128i *)child), none);
    __m128i hi = _mm_cmpeq_epi32(_mm_loadu_si128((const __m128i *)(child + 4)), none);
    unsigned empty = (unsigned)_mm_movemask_ps(_mm_castsi128_ps(lo)) |
                     (unsigned)_mm_movemask_ps(_mm_castsi128_ps(hi)) << 4;
    return ~empty & 0xffu;
#else
    unsigned live = 0;
    for (int k = 0; k < 8; k++)
        live |= (unsigned)(child[k] != TRAVERSAL_EMPTY) << k;
    return live;
#endif
}

/* The two trees together from their roots (see the top of the file). A shape node is
 * tested by its triangles' bounds within its cell (octree_def.node_bounds) where the tree
 * has them, a world leaf by its content. An expansion tests its eight children side by
 * side (the lane tests above) and pushes those that may meet; a pair of leaves goes to
 * leaf_pair. */
static void descend(pose_query *pq, const pose_frame *f)
{
    shape_scratch *s = pq->s;
    const octree *world = s->world, *shape = s->shape;
    query_stats *stats = pq->stats;
    double g = f->content_pad;
    int form = world->traversal.present;
    lane_tests lanes = lane_tests_here();
    pq->frame = f;
    stats->nodes_visited++;
    if (world->nodes[0].count == 0 || shape->nodes[0].count == 0)
        return;
    uint32_t world_root = form ? world->traversal.root : 0;
    if (world_root == TRAVERSAL_EMPTY)
        return;
    if (++s->side_epoch == 0) { /* the slots' stamps wrapped: none is current */
        for (int k = 0; k < SIDE_SLOTS; k++)
            s->shape_sides[k].stamp = s->world_sides[k].stamp = 0;
        s->side_epoch = 1;
    }
    box_side side;
    shape_side_of(f, shape_node_box(shape, 0, shape->world), &side);
    if (world_box_apart(f, world->world, &side))
        return;
    pair_entry *stack = s->stack;
    size_t top = 0;
    stack[top++] = (pair_entry){world_root, 0, world->world, shape->world};
    child_boxes b;
    box3 cells[8];
    while (top > 0) {
        pair_entry e = stack[--top];
        octree_node sn = shape->nodes[e.shape_node];
        int world_leaf = world_is_leaf(world, form, e.world_node), shape_leaf = sn.count != NODE_INTERIOR;
        if (world_leaf && shape_leaf) {
            stats->leaves_visited++;
            octree_node wn = world_leaf_of(world, form, e.world_node);
            box3 content = box_grown(world_leaf_box(world, form, wn, e.world_box), g);
            if (leaf_pair(pq, wn, content, e.shape_node, e.shape_box))
                return;
            continue;
        }
        /* The larger node splits, so the two boxes stay of a size. */
        int split_world = shape_leaf || (!world_leaf && box_extent(e.world_box) >= f->scale * box_width(e.shape_box));
        if (split_world) {
            int fresh;
            side_slot *ss = side_slot_of(s->shape_sides, e.shape_node, s->side_epoch, &fresh);
            if (fresh)
                shape_side_of(f, shape_node_box(shape, e.shape_node, e.shape_box), &ss->side);
            const box_side *shape_side = &ss->side;
            unsigned live = 0, near;
            const uint32_t *refs = NULL;
            uint32_t first = 0;
            if (form) {
                const traversal_node *n = &world->traversal.nodes[e.world_node];
                refs = n->child;
                live = form_live_lanes(refs);
                near = lanes.form(f, world, n, shape_side, live, &b);
            } else {
                octree_node wn = world->nodes[e.world_node];
                vec3 c = octree_split_point(world, e.world_box);
                const octree_node *kids = &world->nodes[wn.first];
                first = wn.first;
                for (int k = 0; k < 8; k++) {
                    live |= (unsigned)(kids[k].count != 0) << k;
                    cells[k] = box_child(e.world_box, c, box_octant_upper_bits[k]);
                }
                near = lanes.world(f, cells, shape_side, live, &b);
            }
            stats->nodes_visited += bits_set8(live);
            for (unsigned m = near; m; m &= m - 1) {
                int k = __builtin_ctz(m);
                uint32_t ref = form ? refs[k] : first + (uint32_t)k;
                stack[top++] = (pair_entry){ref, e.shape_node, lane_of(&b, k), e.shape_box};
            }
        } else {
            if (world_leaf && s->boxed &&
                !world_leaf_near(pq, world_leaf_of(world, form, e.world_node), e.shape_node, e.shape_box))
                continue;
            vec3 c = octree_split_point(shape, e.shape_box);
            const octree_node *kids = &shape->nodes[sn.first];
            int fresh;
            side_slot *ws = side_slot_of(s->world_sides, e.world_node, s->side_epoch, &fresh);
            if (fresh) {
                box3 wb = world_leaf ? world_leaf_box(world, form, world_leaf_of(world, form, e.world_node), e.world_box)
                                     : e.world_box;
                world_side_of(f, wb, &ws->side);
            }
            /* With node bounds the children's lanes were laid out by the build, and their
             * cells are needed only for the pushes. */
            const child_lanes *tested;
            child_lanes of_cells;
            int laid_out = shape->child_lanes != NULL;
            if (laid_out) {
                tested = &shape->child_lanes[sn.first / 8];
            } else {
                for (int k = 0; k < 8; k++)
                    cells[k] = box_child(e.shape_box, c, box_octant_upper_bits[k]);
                child_lanes_of(cells, kids, &of_cells);
                tested = &of_cells;
            }
            unsigned live = tested->live;
            unsigned near = lanes.shape(f, tested, &ws->side, live);
            stats->nodes_visited += bits_set8(live);
            for (unsigned m = near; m; m &= m - 1) {
                int k = __builtin_ctz(m);
                box3 cell = laid_out ? box_child(e.shape_box, c, box_octant_upper_bits[k]) : cells[k];
                stack[top++] = (pair_entry){e.world_node, sn.first + (uint32_t)k, e.world_box, cell};
            }
        }
    }
}

/* Fast and seed mode: every shape triangle posed first, for the candidates outside the
 * trees' lists (octree_triangle's rule, per shape triangle): with an infinite slack
 * (a seed sliver, coordinates beyond the derivations) every world triangle; in seed mode
 * the world's sliver list; in fast mode, for a sliver, the same list. Returns 1 when the
 * query is over, and the largest finite slack in *grow. */
static int mode_candidates(pose_query *pq, double *grow)
{
    shape_scratch *s = pq->s;
    const octree *world = s->world;
    *grow = 0.0;
    if (scratch_arrays(s) != 0) {
        pq->status = OCTREE_ERR_NOMEM;
        return 1;
    }
    for (uint32_t q = 0; q < s->shape->triangle_count; q++) {
        posed_triangle *p = posed_get(s, pq->at, q);
        double slack = s->mode == ACCURACY_FAST ? octree_fast_triangle_slack(world, p->query.v)
                                                : octree_seed_triangle_slack(world, p->query.v);
        size_t extra = 0;
        if (!(slack < INFINITY))
            extra = world->triangle_count;
        else if (s->mode == ACCURACY_SEED || octree_is_sliver(p->query.v))
            extra = world->sliver_list_count;
        for (size_t i = 0; i < extra; i++) {
            uint32_t w = slack < INFINITY ? octree_sliver_list(world)[i] : (uint32_t)i;
            if (take_pair(pq, p, q, w))
                return 1;
        }
        if (slack < INFINITY)
            *grow = fmax(*grow, slack);
    }
    return 0;
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

typedef struct tree_in_caller_order {
    const octree *shape;
    uint32_t *internal; /* internal id of caller's triangle i */
} tree_in_caller_order;

static void triangle_in_caller_order(const void *ctx, size_t i, vec3 out[3])
{
    const tree_in_caller_order *c = ctx;
    octree_triangle_vertices(c->shape, c->internal[i], out);
}

/* The internal id of the caller's triangle i, for every i (NULL when out of memory): the
 * per-triangle paths answer in the caller's order. */
static uint32_t *internal_in_caller_order(const octree *shape)
{
    size_t n = shape->triangle_count;
    uint32_t *internal = malloc((n ? n : 1) * sizeof *internal);
    for (size_t i = 0; internal && i < n; i++)
        internal[shape->original_id[i]] = (uint32_t)i;
    return internal;
}

/* The per-triangle path over a shape tree's triangles, in the caller's order: for poses
 * outside the frame's range. */
static octree_status shape_fallback(const octree *world, const octree *shape, const pose *at, int all_pairs,
                                    accuracy_mode mode, mesh_output *out, query_stats *stats)
{
    size_t n = shape->triangle_count;
    tree_in_caller_order c = {shape, internal_in_caller_order(shape)};
    if (!c.internal)
        return OCTREE_ERR_NOMEM;
    octree_status st =
        octree_mesh_per_triangle(world, &c, n, triangle_in_caller_order, at, all_pairs, mode, out, stats);
    free(c.internal);
    return st;
}

static int valid_mode(accuracy_mode mode)
{
    return mode == ACCURACY_EXACT || mode == ACCURACY_SEED || mode == ACCURACY_FAST;
}

static octree_status check_pose(const pose *at)
{
    for (int k = 0; k < 9; k++)
        if (!isfinite(at->r[k]))
            return OCTREE_ERR_NONFINITE;
    return vec3_is_finite(at->t) ? OCTREE_OK : OCTREE_ERR_NONFINITE;
}

/* An all-pairs answer from the scratch's hits: sorted, as many as fit, every one counted. */
static void pairs_out(shape_scratch *s, mesh_output *out)
{
    if (s->hit_count > 1)
        qsort(s->hits, s->hit_count, sizeof *s->hits, compare_u64);
    size_t keep = s->hit_count < out->capacity ? s->hit_count : out->capacity;
    for (size_t i = 0; i < keep; i++)
        out->pairs[i] = (mesh_pair){(uint32_t)(s->hits[i] >> 32), (uint32_t)s->hits[i]};
    out->count = s->hit_count;
    out->truncated = s->hit_count > out->capacity;
}

/* One pose with the scratch of its call. */
static octree_status mesh_tree_pose(shape_scratch *s, const pose *at, int all_pairs, mesh_output *out,
                                    query_stats *stats)
{
    if (!at)
        return OCTREE_ERR_INVALID;
    octree_status st = check_pose(at);
    if (st != OCTREE_OK)
        return st;
    uint64_t fallbacks_before = predicates_fallback_count();
    query_stats local = {0};
    scratch_next_pose(s);
    pose_query pq = {.s = s, .at = at, .all_pairs = all_pairs, .status = OCTREE_OK, .stats = &local};
    double grow = 0.0;
    int over = 0;
    /* The frame's range is checked before anything is posed: outside it, the per-triangle
     * path answers (and reports a posed coordinate that overflows as it always has). */
    pose_frame f;
    if (!pose_frame_make(&f, s->world, s->shape, at, 0.0))
        return shape_fallback(s->world, s->shape, at, all_pairs, s->mode, out, stats);
    if (s->mode != ACCURACY_EXACT)
        over = mode_candidates(&pq, &grow);
    if (!over && grow > 0.0 && !pose_frame_make(&f, s->world, s->shape, at, grow))
        return shape_fallback(s->world, s->shape, at, all_pairs, s->mode, out, stats);
    if (!over)
        descend(&pq, &f);
    out->hit = pq.any;
    out->count = 0;
    out->truncated = 0;
    if (pq.status == OCTREE_OK && all_pairs)
        pairs_out(s, out);
    query_stats_finish(stats, &local, fallbacks_before, predicates_fallback_count());
    return pq.status;
}

/* The per-triangle path for a placed world, in the caller's order: each shape triangle
 * posed at shape_at, against the world tree placed at world_at (octree_triangle_posed).
 * For poses outside the frame's range. */
static octree_status placed_fallback(const octree *world, const pose *world_at, const octree *shape,
                                     const pose *shape_at, int all_pairs, mesh_output *out, query_stats *stats)
{
    size_t n = shape->triangle_count;
    uint32_t *internal = internal_in_caller_order(shape);
    size_t cap = 16;
    tri_contact *contacts = malloc(cap * sizeof *contacts);
    octree_status st = internal && contacts ? OCTREE_OK : OCTREE_ERR_NOMEM;
    out->hit = 0;
    out->count = 0;
    for (size_t i = 0; st == OCTREE_OK && i < n; i++) {
        vec3 q[3];
        octree_triangle_vertices(shape, internal[i], q);
        for (int k = 0; k < 3; k++)
            q[k] = octree_apply_pose(shape_at, q[k]);
        tri_output t = {.contacts = contacts, .capacity = cap};
        st = octree_triangle_posed(world, world_at, q, TRI_IDS, ACCURACY_EXACT, &t, stats);
        if (st == OCTREE_OK && t.truncated) {
            tri_contact *more = realloc(contacts, t.count * sizeof *contacts);
            if (!more) {
                st = OCTREE_ERR_NOMEM;
                break;
            }
            contacts = more;
            cap = t.count;
            t = (tri_output){.contacts = contacts, .capacity = cap};
            st = octree_triangle_posed(world, world_at, q, TRI_IDS, ACCURACY_EXACT, &t, stats);
        }
        if (st != OCTREE_OK || !t.hit)
            continue;
        out->hit = 1;
        if (!all_pairs) { /* the first contact: this triangle's first */
            if (out->capacity > 0)
                out->pairs[0] = (mesh_pair){(uint32_t)i, contacts[0].triangle};
            out->count = 1;
            break;
        }
        for (size_t j = 0; j < t.count; j++) {
            if (out->count < out->capacity)
                out->pairs[out->count] = (mesh_pair){(uint32_t)i, contacts[j].triangle};
            out->count++;
        }
    }
    out->truncated = out->count > out->capacity;
    free(internal);
    free(contacts);
    return st;
}

struct octree_shape_scratch {
    shape_scratch *s;
};

octree_shape_scratch *octree_shape_scratch_new(const octree *shape)
{
    if (!shape)
        return NULL;
    octree_shape_scratch *x = malloc(sizeof *x);
    if (!x)
        return NULL;
    /* Made for the shape against itself; each query points it at its world. */
    x->s = scratch_new(shape, shape, ACCURACY_EXACT);
    if (!x->s) {
        free(x);
        return NULL;
    }
    return x;
}

void octree_shape_scratch_free(octree_shape_scratch *x)
{
    if (!x)
        return;
    scratch_free(x->s);
    free(x);
}

/* Points the scratch at world: a stack deep enough for the two trees. Stamps, sides and
 * the pair set are per pose and per descent already, so nothing else is cleared. */
static int scratch_retarget(shape_scratch *s, const octree *world)
{
    size_t need = stack_capacity(world, s->shape);
    if (need > s->stack_cap) {
        pair_entry *more = realloc(s->stack, need * sizeof *more);
        if (!more)
            return -1;
        s->stack = more;
        s->stack_cap = need;
    }
    s->world = world;
    s->boxed = 0; /* a placed world goes without the float boxes' filters */
    return 0;
}

octree_status octree_mesh_tree_posed_with(octree_shape_scratch *x, const octree *world, const pose *world_at,
                                          const pose *shape_at, int all_pairs, mesh_output *out, query_stats *stats)
{
    if (!x || !world || !world_at || !shape_at || !out)
        return OCTREE_ERR_INVALID;
    shape_scratch *s = x->s;
    const octree *shape = s->shape;
    pose relative;
    double grow;
    octree_status st = octree_posed_pair_setup(world, world_at, shape, shape_at, &relative, &grow);
    if (st != OCTREE_OK)
        return st;
    pose_frame f;
    if (!pose_frame_make(&f, world, shape, &relative, grow))
        return placed_fallback(world, world_at, shape, shape_at, all_pairs, out, stats);
    if (scratch_retarget(s, world) != 0)
        return OCTREE_ERR_NOMEM;
    s->world_at = world_at;
    s->shape_at = shape_at;
    uint64_t fallbacks_before = predicates_fallback_count();
    query_stats local = {0};
    scratch_next_pose(s);
    pose_query pq = {.s = s, .at = &relative, .all_pairs = all_pairs, .status = OCTREE_OK, .stats = &local};
    descend(&pq, &f);
    out->hit = pq.any;
    out->count = 0;
    out->truncated = 0;
    if (pq.status == OCTREE_OK && !all_pairs && pq.any) {
        if (out->capacity > 0)
            out->pairs[0] = (mesh_pair){(uint32_t)(pq.first >> 32), (uint32_t)pq.first};
        out->count = 1;
    }
    if (pq.status == OCTREE_OK && all_pairs)
        pairs_out(s, out);
    query_stats_finish(stats, &local, fallbacks_before, predicates_fallback_count());
    return pq.status;
}

octree_status octree_mesh_tree_posed(const octree *world, const pose *world_at, const octree *shape,
                                     const pose *shape_at, int all_pairs, accuracy_mode mode, mesh_output *out,
                                     query_stats *stats)
{
    if (!world || !shape || !world_at || !shape_at || !out || mode != ACCURACY_EXACT)
        return OCTREE_ERR_INVALID;
    octree_shape_scratch *x = octree_shape_scratch_new(shape);
    if (!x)
        return OCTREE_ERR_NOMEM;
    octree_status st = octree_mesh_tree_posed_with(x, world, world_at, shape_at, all_pairs, out, stats);
    octree_shape_scratch_free(x);
    return st;
}

/* Every pose of one call with one scratch. OCTREE_OK unless memory ran out for the
 * scratch (then every status says so). */
static octree_status mesh_tree_poses(const octree *world, const octree *shape, const pose *poses, size_t count,
                                     int all_pairs, accuracy_mode mode, mesh_output *outs, octree_status *statuses,
                                     query_stats *stats)
{
    if (!world || !shape || !valid_mode(mode) || !poses || !outs) {
        for (size_t i = 0; i < count; i++)
            statuses[i] = OCTREE_ERR_INVALID;
        return OCTREE_OK;
    }
    shape_scratch *s = scratch_new(world, shape, mode);
    if (!s) {
        for (size_t i = 0; i < count; i++)
            statuses[i] = OCTREE_ERR_NOMEM;
        return OCTREE_ERR_NOMEM;
    }
    octree_status batch = OCTREE_OK;
    for (size_t i = 0; i < count; i++) {
        statuses[i] = mesh_tree_pose(s, &poses[i], all_pairs, &outs[i], stats);
        if (statuses[i] == OCTREE_ERR_NOMEM)
            batch = OCTREE_ERR_NOMEM;
    }
    scratch_free(s);
    return batch;
}

octree_status octree_mesh_tree(const octree *world, const octree *shape, const pose *at, int all_pairs,
                               accuracy_mode mode, mesh_output *out, query_stats *stats)
{
    octree_status st = OCTREE_OK;
    mesh_tree_poses(world, shape, at, 1, all_pairs, mode, out, &st, stats);
    return st;
}

octree_status octree_mesh_tree_batch(const octree *world, const octree *shape, const pose *poses, size_t count,
                                     int all_pairs, accuracy_mode mode, mesh_output *outs, octree_status *statuses,
                                     query_stats *stats)
{
    if (count == 0)
        return OCTREE_OK;
    return mesh_tree_poses(world, shape, poses, count, all_pairs, mode, outs, statuses, stats);
}

/* ---------- shapes given as meshes ---------- */

/* Whether building the shape's tree for `poses` poses costs less than searching the world
 * from the root for each posed triangle (bench/bench_shapes.c measures both). The build
 * costs about as much as a few poses' per-triangle searches, so a lone pose or a handful
 * (octree_mesh, small batches) takes the per-triangle path. */
#define SHAPE_TREE_MIN_TRIANGLES 8
#define SHAPE_TREE_MIN_POSES 8

static int shape_tree_pays(size_t triangles, size_t poses)
{
    return triangles >= SHAPE_TREE_MIN_TRIANGLES && poses >= SHAPE_TREE_MIN_POSES;
}

/* The shape's tree, or NULL when it cannot be built (over its budget, out of memory, an
 * extent the builder refuses): the per-triangle path then answers. */
octree *octree_shape_tree_for(const mesh_view *shape, size_t poses)
{
    if (!shape_tree_pays(shape->triangle_count, poses))
        return NULL;
    octree_def def = octree_default_def();
    def.node_bounds = 1;
    return octree_build(shape, &def, NULL);
}

static void triangle_of_view(const void *shape, size_t i, vec3 out[3])
{
    const mesh_view *v = shape;
    for (int k = 0; k < 3; k++)
        out[k] = v->vertices[v->indices[3 * i + (size_t)k]];
}

octree_status octree_mesh_as_triangles(const octree *tree, const mesh_view *shape, const pose *at, int all_pairs,
                                       accuracy_mode mode, mesh_output *out, query_stats *stats)
{
    octree_status st = octree_mesh_check(shape, at, mode);
    if (st != OCTREE_OK)
        return st;
    return octree_mesh_per_triangle(tree, shape, shape->triangle_count, triangle_of_view, at, all_pairs, mode, out,
                                    stats);
}

octree_status octree_mesh(const octree *tree, const mesh_view *shape, const pose *at, int all_pairs,
                          accuracy_mode mode, mesh_output *out, query_stats *stats)
{
    octree_status st = octree_mesh_check(shape, at, mode);
    if (st != OCTREE_OK)
        return st;
    octree *shape_tree = octree_shape_tree_for(shape, 1);
    if (!shape_tree)
        return octree_mesh_per_triangle(tree, shape, shape->triangle_count, triangle_of_view, at, all_pairs, mode,
                                        out, stats);
    st = octree_mesh_tree(tree, shape_tree, at, all_pairs, mode, out, stats);
    octree_free(shape_tree);
    return st;
}
