/* trioct engine: fixed-resolution triangle octree and the queries it answers.
 * The one public header of libtrioct_engine; no I/O, no network, no global state. */
#ifndef TRIOCT_ENGINE_H
#define TRIOCT_ENGINE_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

typedef struct vec3 {
    double x, y, z;
} vec3;

/* A closed axis-aligned box [lo, hi]. */
typedef struct box3 {
    vec3 lo, hi;
} box3;

/* How a test decides. See docs/accuracy.md for each mode's contract. */
typedef enum accuracy_mode {
    ACCURACY_EXACT = 0, /* exact arithmetic on the double inputs (filtered, exact fallback) */
    ACCURACY_SEED = 1,  /* the seed document's epsilon tests, as written */
    ACCURACY_FAST = 2,  /* plain double tests, no exactness guarantee */
} accuracy_mode;

const char *accuracy_mode_name(accuracy_mode mode);

/* Engine status codes: 0 is success, errors are negative. */
#define OCTREE_STATUS_MAP(X)                                                       \
    X(OCTREE_OK, 0, "ok")                                                          \
    X(OCTREE_ERR_INVALID, -1, "invalid argument")                                  \
    X(OCTREE_ERR_NONFINITE, -2, "a coordinate is NaN or infinite")                 \
    X(OCTREE_ERR_INDEX, -3, "triangle refers to a vertex that does not exist")     \
    X(OCTREE_ERR_DEPTH, -4, "resolution needs more levels than the depth cap")     \
    X(OCTREE_ERR_NOMEM, -5, "out of memory")                                       \
    X(OCTREE_ERR_TOO_BIG, -6, "more triangles or nodes than the engine addresses") \
    X(OCTREE_ERR_EMPTY, -7, "no triangles")                                       \
    X(OCTREE_ERR_BUDGET, -8, "the build needs more memory than its budget")

typedef enum octree_status {
#define OCTREE_STATUS_ENUM(name, code, text) name = code,
    OCTREE_STATUS_MAP(OCTREE_STATUS_ENUM)
#undef OCTREE_STATUS_ENUM
} octree_status;

const char *octree_status_text(octree_status status);

/* The deepest octree the engine builds. 2^21 leaves a side keeps every node's integer
 * coordinates in 21 bits, and a tree this deep over a real mesh already needs far more
 * memory than a machine has. A resolution asking for more is an error (OCTREE_ERR_DEPTH)
 * when given explicitly; the seed's heuristic resolution is clamped to it. */
#define OCTREE_MAX_DEPTH_CAP 21

/* Bytes shared by builds that may run at once: a daemon's memory budget. A build takes
 * from it each block before allocating it and stops with OCTREE_ERR_BUDGET when the
 * account has no room; the finished tree keeps what it holds and gives it back when freed.
 * Thread-safe. */
typedef struct memory_account {
    atomic_size_t used;
    size_t limit; /* SIZE_MAX: none */
} memory_account;

/* An account with nothing used. */
void memory_account_init(memory_account *account, size_t limit);
/* Takes bytes when they fit under the limit: 0, or -1 with nothing taken. */
int memory_account_take(memory_account *account, size_t bytes);
/* Takes bytes whether they fit or not: for memory already allocated, to keep the count true. */
void memory_account_charge(memory_account *account, size_t bytes);
void memory_account_give(memory_account *account, size_t bytes);
size_t memory_account_used(const memory_account *account);
/* What is left under the limit (0 when at or past it). */
size_t memory_account_left(const memory_account *account);

typedef struct octree_def {
    double resolution;    /* leaf side d; <= 0 asks for the seed's heuristic sqrt(mean |E2 x E0|) */
    int max_depth;        /* cap on L_max, 0..OCTREE_MAX_DEPTH_CAP */
    accuracy_mode mode;   /* membership test used while building, and default for queries */
    double seed_epsilon;  /* epsilon of the seed's tests (ACCURACY_SEED only) */
    /* 1: precompute each triangle's axis-aligned box (24 bytes a triangle: floats relative
     * to the world's lower corner, rounded outward), which triangle and mesh queries use to
     * skip candidates whose box misses the query triangle's box. Answers are the same
     * either way. Only exact-mode queries skip: the seed and fast tests can report
     * triangles whose boxes are apart, so there a skip would change the answer. Ray queries
     * never read the boxes. 0 (the default): none. */
    int triangle_boxes;
    /* 1: store each node's exact bounds of its triangles within its box (48 bytes a node),
     * which mesh queries use on the shape side (octree_mesh_tree) to drop node pairs the
     * node's box alone would keep; for a tree built as a query shape. Answers are the same
     * either way. 0 (the default): none. */
    int node_bounds;
    /* 1: store what distance queries walk (128 bytes a node and 4 a triangle): each
     * triangle owned by one node, with each node's bounds of the triangles it owns, so that
     * a walk meets a triangle once where the leaves list it several times; and each node's
     * slab, the range of those triangles along their mean normal and two axes across it:
     * a surface's piece is as thin along its normal as it is flat. Answers are the same
     * either way. 0 (the default): none. */
    int node_slabs;
    /* The most memory the build may hold, in bytes: its copy of the mesh, the nodes, the
     * leaf lists and the lists it holds while building, each growing array counted at the
     * capacity it is about to take. A build that would pass it stops with
     * OCTREE_ERR_BUDGET, naming the budget and what it held, and frees everything. 0 (the
     * default) is OCTREE_DEFAULT_BUDGET_BASE + OCTREE_DEFAULT_BUDGET_PER_TRIANGLE per
     * triangle, about forty times what real meshes take; SIZE_MAX is no budget. */
    size_t budget_bytes;
    /* Shared with other builds and trees: the build takes every byte it counts against
     * budget_bytes from it as well. NULL (the default): none. */
    memory_account *account;
    /* 1: no compiled traversal form (octree_traversal.h, about 20-30 bytes a triangle):
     * rays take the double-precision walk over the seed's nodes, with the same answers
     * (any-hit rays may report another of their hits), more slowly. 0 (the default):
     * rays walk the compiled form. */
    int plain_walk;
} octree_def;

/* The default build budget: real meshes take 100-115 bytes a triangle in all; a build past
 * 4 KiB a triangle (and 256 MiB) is a resolution or a mode gone wrong (a needle triangle
 * at the depth cap, the seed's epsilon at the world's own scale). */
#define OCTREE_DEFAULT_BUDGET_BASE ((size_t)256 << 20)
#define OCTREE_DEFAULT_BUDGET_PER_TRIANGLE ((size_t)4096)

octree_def octree_default_def(void);
/* The budget a build of this many triangles has when budget_bytes is 0:
 * OCTREE_DEFAULT_BUDGET_BASE + OCTREE_DEFAULT_BUDGET_PER_TRIANGLE a triangle, or SIZE_MAX
 * when that does not fit. */
size_t octree_default_budget(size_t triangles);

/* Input mesh: vertex array plus three vertex indices per triangle. */
typedef struct mesh_view {
    const vec3 *vertices;
    size_t vertex_count;
    const uint32_t *indices; /* 3 * triangle_count */
    size_t triangle_count;
} mesh_view;

typedef struct octree octree;

/* Where a build failed: the offending triangle when there is one. */
typedef struct octree_error {
    octree_status status;
    size_t triangle;   /* index of the offending triangle, or SIZE_MAX */
    char message[160];
} octree_error;

/* Builds an immutable octree over a copy of the mesh. On failure returns NULL and fills
 * err (when not NULL). The result is safe for concurrent queries from many threads.
 * Vertices may be any finite doubles, up to +-DBL_MAX, as long as the mesh's extent along
 * each axis is itself a double (at most DBL_MAX: not vertices near both -DBL_MAX and
 * +DBL_MAX), else OCTREE_ERR_INVALID ("the mesh extent overflows a double"). Queries take
 * any finite coordinates, however far from the world. */
octree *octree_build(const mesh_view *mesh, const octree_def *def, octree_error *err);
void octree_free(octree *tree);

typedef struct octree_info {
    size_t triangle_count;
    size_t vertex_count;
    size_t node_count;
    size_t leaf_count;
    size_t nonempty_leaf_count;
    size_t leaf_refs;          /* total triangle references held by leaves */
    int max_level;             /* L_max */
    int depth_clamped;         /* 1 when the heuristic resolution was clamped to the cap */
    double resolution;         /* d actually used */
    double world_size;         /* D = 2^L_max * d */
    vec3 world_min;            /* the world cube is [world_min, world_min + D], its upper
                                  corner rounded up so that it holds every vertex */
    size_t bytes_nodes, bytes_leaf_lists, bytes_triangles, bytes_total;
    size_t bytes_triangle_boxes; /* 24 per triangle with octree_def.triangle_boxes, else 0;
                                    part of bytes_total */
    size_t bytes_traversal;      /* the compiled form rays walk (96 bytes an interior node);
                                    part of bytes_total */
    size_t bytes_node_bounds;    /* with octree_def.node_bounds 48 per node and 392 per block
                                    of eight children (their bounds laid out for the lane
                                    tests), else 0; part of bytes_total */
    size_t bytes_node_slabs;     /* with octree_def.node_slabs 128 per node (the slab, the
                                    owned span and bounds) and 4 per triangle (the owned
                                    lists), else 0; part of bytes_total */
    double build_seconds;
    accuracy_mode mode;
} octree_info;

/* Defined while octree_def has triangle_boxes and octree_info has bytes_triangle_boxes. */
#define OCTREE_HAS_TRIANGLE_BOXES 1

void octree_get_info(const octree *tree, octree_info *info);

/* The world cube, its upper corner as built (rounded up): every vertex lies in it. */
box3 octree_world_box(const octree *tree);

/* ---------- queries ---------- */

/* What a query visited: honest work counters. */
typedef struct query_stats {
    uint64_t nodes_visited;
    uint64_t leaves_visited;
    uint64_t candidates_tested;  /* full primitive tests run */
    uint64_t exact_fallbacks;    /* predicate evaluations that needed exact arithmetic */
} query_stats;

typedef enum ray_detail {
    RAY_ANY = 0,     /* stop at the first confirmed hit */
    RAY_CLOSEST = 1, /* smallest t, ties to the smaller triangle id */
    RAY_ALL = 2,     /* every hit (crossing or touch), ordered by exact t then triangle id */
} ray_detail;

/* How a ray meets a triangle (docs/engine.md, "Contact rules"). */
typedef enum ray_contact {
    /* Watertight: each crossing of a surface counted once; a ray lying in a triangle's
     * plane, a zero-area triangle and an edge or vertex a neighbour claims do not count. */
    RAY_CROSSING = 0,
    /* The ray segment and the closed triangle share a point: boundary contacts, in-plane
     * rays and zero-area triangles count, so RAY_ANY is a conservative line-of-sight
     * test; t is the smallest common t. Exact mode only (OCTREE_ERR_INVALID otherwise). */
    RAY_TOUCH = 1,
} ray_contact;

typedef struct ray_input {
    vec3 origin;
    vec3 direction;   /* need not be unit length; t is in units of |direction| */
    double tmin, tmax; /* closed interval; tmin finite, tmax may be INFINITY */
    ray_contact contact; /* zero-initialised: RAY_CROSSING */
} ray_input;

typedef struct ray_hit {
    double t;
    uint32_t triangle;
    double u, v;  /* barycentric weights of vertices 1 and 2 */
    vec3 normal;  /* unit geometric normal (v1-v0)x(v2-v0); (0, 0, 0) for a zero-area
                     triangle (only RAY_TOUCH hits those) */
} ray_hit;

/* Results of one ray. For RAY_ALL the hits go to `hits` (capacity `max_hits`); hit_count
 * is the number of crossings found, which may exceed max_hits (then `truncated` is 1 and
 * the first max_hits are stored). For ANY/CLOSEST, hits[0] holds the answer when hit_count>0. */
typedef struct ray_output {
    size_t hit_count;
    int truncated;
    ray_hit *hits;
    size_t max_hits;
} ray_output;

/* Returns OCTREE_OK, or OCTREE_ERR_INVALID/NONFINITE for a bad ray (zero or non-finite
 * direction, NaN origin, tmin > tmax, an unknown contact, RAY_TOUCH with a mode other
 * than ACCURACY_EXACT). mode selects the primitive test. */
octree_status octree_ray(const octree *tree, const ray_input *ray, ray_detail detail,
                         accuracy_mode mode, ray_output *out, query_stats *stats);

typedef enum tri_detail {
    TRI_YESNO = 0,    /* stop at the first confirmed contact */
    TRI_IDS = 1,      /* sorted unique ids of world triangles touched */
    TRI_SEGMENTS = 2, /* ids plus the contact segment of each pair */
} tri_detail;

typedef struct tri_contact {
    uint32_t triangle;
    vec3 p, q; /* contact segment (p == q for a point contact); area contacts give an
                  extreme pair of the overlap polygon */
} tri_contact;

typedef struct tri_output {
    int hit;                 /* any contact */
    size_t count;            /* contacts found (may exceed capacity: truncated = 1) */
    int truncated;
    tri_contact *contacts;   /* capacity entries; ids only unless TRI_SEGMENTS */
    size_t capacity;
} tri_output;

octree_status octree_triangle(const octree *tree, const vec3 tri[3], tri_detail detail,
                              accuracy_mode mode, tri_output *out, query_stats *stats);

/* A rigid pose: p' = R p + t, R row-major 3x3. */
typedef struct pose {
    double r[9];
    vec3 t;
} pose;

/* Poses of objects placed in a world (octree_ray_posed). A local vertex p is placed at
 * fl(R p + t), each coordinate computed as ((r0 p.x + r1 p.y) + r2 p.z) + t.x with each
 * operation rounded on its own: octree_pose_point, the one expression every posed query
 * uses, so answers are exact on those doubles. */
vec3 octree_pose_point(const pose *at, vec3 p);

/* R = I and t = 0: octree_pose_point then returns every point unchanged (up to the sign
 * of a zero), so a tree at the identity is queried as it stands. */
pose octree_pose_identity(void);
int octree_pose_is_identity(const pose *at);

/* Largest |(R^T R - I)_ij| a pose's R may have, and the relative amount a quaternion's
 * length may differ from 1: within these a pose is taken as the rotation it approximates
 * (a matrix typed with six decimals passes), past them it is refused as a mistake. */
#define OCTREE_ROTATION_TOLERANCE 1e-6
#define OCTREE_QUATERNION_TOLERANCE 1e-3 /* TRIOCT_QUATERNION_TOLERANCE (common/quaternion.h) */

/* OCTREE_OK when R is a rotation within OCTREE_ROTATION_TOLERANCE (orthonormal, det +1)
 * and every entry is finite; OCTREE_ERR_NONFINITE, or OCTREE_ERR_INVALID for a matrix
 * that is not a rotation (a scale, a shear, a reflection). */
octree_status octree_pose_check(const pose *at);

/* The pose of translation t and the rotation of quaternion (qw, qx, qy, qz), normalised
 * first; OCTREE_ERR_INVALID when its length is not 1 within OCTREE_QUATERNION_TOLERANCE,
 * OCTREE_ERR_NONFINITE for a NaN or infinite component. */
octree_status octree_pose_from_quaternion(vec3 t, double qw, double qx, double qy, double qz, pose *out);

/* The smallest box holding octree_pose_point(at, p) for every p in `local`: the posed
 * corners' box (octree_pose.c says why that suffices). What a top-level structure over
 * posed objects needs, in O(1) a move. */
box3 octree_pose_box(const pose *at, box3 local);

/* An interval [*t0, *t1] holding every t at which o + t d is in the closed box b, widened
 * for its rounding; 0 when the ray's line misses the box (then *t0, *t1 are unset). */
int octree_ray_box_interval(vec3 o, vec3 d, box3 b, double *t0, double *t1);

/* octree_ray's checks of a ray and its detail and mode, alone: OCTREE_OK or the status
 * octree_ray would return for them. */
octree_status octree_ray_check(const ray_input *ray, ray_detail detail, accuracy_mode mode);

/* A ray in world coordinates against a tree built in its local frame and placed at `at`:
 * the answers octree_ray would give on a tree built from the posed triangles
 * (octree_pose_point of every vertex), the same t, barycentrics, normal and triangle
 * ids, with no tree built for the pose. The walk runs in the local frame, widened by
 * what the pose's rounding can move a point (octree_pose.c); the final tests run on the
 * posed vertices and the world ray. ACCURACY_EXACT only; OCTREE_ERR_INVALID for another
 * mode or a pose octree_pose_check refuses. */
octree_status octree_ray_posed(const octree *tree, const pose *at, const ray_input *ray, ray_detail detail,
                               accuracy_mode mode, ray_output *out, query_stats *stats);

/* A triangle in world coordinates against a tree placed at `at`: octree_triangle's answer
 * on a tree of the posed triangles (contacts name the tree's triangles, segments are in
 * world space), with no tree built for the pose. ACCURACY_EXACT only. */
octree_status octree_triangle_posed(const octree *tree, const pose *at, const vec3 tri[3], tri_detail detail,
                                    accuracy_mode mode, tri_output *out, query_stats *stats);

/* The exact order of two hits of one ray (both triangles hit by it under its contact
 * rule, in exact mode): -1, 0, +1 for t_a <, =, > t_b. What merges the answers of several
 * posed trees (a world of objects) into one closest hit or one ordered list, where the
 * rounded t of two hits may tie or mislead. */
int octree_ray_hit_order(const ray_input *ray, const vec3 a[3], const vec3 b[3]);

typedef struct mesh_pair {
    uint32_t query_triangle;
    uint32_t world_triangle;
} mesh_pair;

typedef struct mesh_output {
    int hit;
    size_t count;
    int truncated;
    mesh_pair *pairs; /* sorted by (query, world) */
    size_t capacity;
} mesh_output;

/* Query mesh under a pose against the world: yes/no (all_pairs = 0) or every pair. The
 * shape is built into its own octree for the call (octree_mesh_tree's path) unless it is
 * too small for that to pay or its tree cannot be built; the answers are the same. */
octree_status octree_mesh(const octree *tree, const mesh_view *shape, const pose *at,
                          int all_pairs, accuracy_mode mode, mesh_output *out,
                          query_stats *stats);

/* The same query with the shape built once into its own octree (octree_build over the
 * shape in its local frame; a registered shape's tree lives as long as its world): the
 * world tree and the shape tree are descended together, so a pose costs what the part of
 * the shape near the world costs. Answers, ids and truncation are exactly octree_mesh's
 * for the mesh the shape tree was built from, in every mode; query_triangle is that
 * mesh's triangle index. Stats count node pairs tested (nodes_visited), leaf pairs
 * (leaves_visited) and triangle pairs tested (candidates_tested). OCTREE_ERR_INVALID for
 * a NULL tree, pose or output or an unknown mode, OCTREE_ERR_NONFINITE for a pose with a
 * NaN or infinite entry, or for a posed vertex that overflows. */
octree_status octree_mesh_tree(const octree *world, const octree *shape, const pose *at,
                               int all_pairs, accuracy_mode mode, mesh_output *out,
                               query_stats *stats);

/* A shape tree placed at shape_at against a world tree placed at world_at (each in its
 * own frame: a robot link against an object): octree_mesh_tree's answer for the two
 * posed meshes, every vertex posed by octree_pose_point, with no tree built for either
 * pose. Pairs name the shape's and the world's triangles by their meshes' indices; for
 * yes/no, a hit also gives the first pair the descent met (count 1, in pairs[0] when
 * capacity allows), so a state check can say what collided. ACCURACY_EXACT only; OCTREE_ERR_INVALID for another mode or a pose octree_pose_check
 * refuses. */
octree_status octree_mesh_tree_posed(const octree *world, const pose *world_at, const octree *shape,
                                     const pose *shape_at, int all_pairs, accuracy_mode mode, mesh_output *out,
                                     query_stats *stats);

/* What octree_mesh_tree_posed allocates for one shape (its stack, the posed triangles'
 * caches, the tested pairs), kept for many queries: a state check asks each link against
 * several objects, state after state, and allocating and clearing it per query cost more
 * than the queries. One scratch serves one thread at a time. */
typedef struct octree_shape_scratch octree_shape_scratch;
octree_shape_scratch *octree_shape_scratch_new(const octree *shape);
void octree_shape_scratch_free(octree_shape_scratch *scratch);
/* octree_mesh_tree_posed (exact mode) for the scratch's shape. */
octree_status octree_mesh_tree_posed_with(octree_shape_scratch *scratch, const octree *world, const pose *world_at,
                                          const pose *shape_at, int all_pairs, mesh_output *out,
                                          query_stats *stats);

/* ---------- solids: inside, outside or on the surface ---------- */
/* For a tree whose mesh is closed (every edge of its triangles used by exactly two of them
 * in opposite directions, as server/world/solid_check.h checks), where a point lies,
 * exactly on the posed vertices (docs/engine.md, "Solid objects"). */
typedef enum point_side {
    POINT_OUTSIDE = 0,
    POINT_INSIDE = 1,     /* an odd number of watertight crossings on a ray from the point */
    POINT_ON_SURFACE = 2, /* the point is on a closed triangle (its face, an edge, a vertex) */
} point_side;

/* Where p lies against the tree placed at `at`: on the surface when it touches a triangle
 * (the exact closed test of a triangle query with p as a point), else inside when a ray
 * from p crosses the surface an odd number of times under RAY_CROSSING, whose symbolic
 * perturbation makes the parity that of a ray missing every edge and vertex. The answer
 * means inside only for a closed mesh; on an open one it is the parity of one ray.
 * OCTREE_ERR_NONFINITE for a non-finite p, OCTREE_ERR_INVALID for a pose
 * octree_pose_check refuses. */
octree_status octree_point_side_posed(const octree *tree, const pose *at, vec3 p, point_side *side,
                                      query_stats *stats);

/* One vertex of each connected part of the tree's mesh (triangles joined by shared
 * vertices), in its frame, and a triangle of that part (the caller's id): points[0..cap)
 * and triangles[0..cap) filled, the count of parts returned (more than cap: call again
 * with room for them), SIZE_MAX when out of memory. What decides, for a shape touching no
 * triangle of a closed surface, whether each part lies inside it. */
size_t octree_component_points(const octree *tree, vec3 *points, uint32_t *triangles, size_t cap);

/* ---------- batches ---------- */
/* Each item gets its own status in statuses[i] and its own output; the batch returns
 * OCTREE_OK when every item was answered (an item's own error is not a batch error) and
 * stats sums every item's counters. */
octree_status octree_ray_batch(const octree *tree, const ray_input *rays, size_t count, ray_detail detail,
                               accuracy_mode mode, ray_output *outs, octree_status *statuses,
                               query_stats *stats);
octree_status octree_triangle_batch(const octree *tree, const vec3 (*tris)[3], size_t count,
                                    tri_detail detail, accuracy_mode mode, tri_output *outs,
                                    octree_status *statuses, query_stats *stats);
/* One shape at many poses; the shape's tree is built once for the batch (see octree_mesh). */
octree_status octree_mesh_batch(const octree *tree, const mesh_view *shape, const pose *poses, size_t count,
                                int all_pairs, accuracy_mode mode, mesh_output *outs,
                                octree_status *statuses, query_stats *stats);
/* One shape tree at many poses, as octree_mesh_tree answers each. */
octree_status octree_mesh_tree_batch(const octree *world, const octree *shape, const pose *poses,
                                     size_t count, int all_pairs, accuracy_mode mode,
                                     mesh_output *outs, octree_status *statuses,
                                     query_stats *stats);

/* ---------- distances ---------- */
/* The part of a triangle a nearest point lies on. Edge k joins vertices k and k + 1
 * (mod 3); vertex k is the triangle's vertex k. */
typedef enum distance_feature {
    DISTANCE_FACE = 0,
    DISTANCE_EDGE = 1,
    DISTANCE_VERTEX = 2,
} distance_feature;

/* A distance with its proven error (docs/engine.md, "Distances"): the real distance of the
 * double inputs lies in [lower, upper], and distance is their midpoint, so
 * |distance - real| <= bound = (upper - lower) / 2 rounded up. */
typedef struct distance_output {
    int found;          /* 0: every triangle is proven farther than max_distance */
    double distance, bound;
    double lower, upper;
    vec3 point;         /* the nearest point found on the world, rounded */
    uint32_t triangle;  /* the caller's id of the triangle it lies on */
    distance_feature feature;
    int feature_index;  /* the edge or vertex number (0 for a face) */
} distance_output;

/* The nearest point of the tree's triangles to p: walked nearest node first (each node's
 * box distance a lower bound, the best upper bound so far the search radius), every
 * candidate bounded in outward-rounded interval arithmetic. Triangles proven farther than
 * max_distance (INFINITY: no limit) are not looked for; found is 0 when none is nearer.
 * Ties in upper go to the smaller triangle id. OCTREE_ERR_NONFINITE for a non-finite p,
 * OCTREE_ERR_INVALID for a NaN or negative max_distance. Every accuracy mode's tree
 * answers it exactly alike. */
octree_status octree_point_distance(const octree *tree, vec3 p, double max_distance, distance_output *out,
                                    query_stats *stats);

/* The same against a tree placed at `at`: the answer on a tree of the posed triangles
 * (octree_pose_point of each vertex), the walk run in the tree's frame. */
octree_status octree_point_distance_posed(const octree *tree, const pose *at, vec3 p, double max_distance,
                                          distance_output *out, query_stats *stats);

/* The nearest points of a shape and a world, with the distance's proven bounds as in
 * distance_output. */
typedef struct shape_distance_output {
    int found; /* 0: every pair of triangles is proven farther than max_distance */
    double distance, bound;
    double lower, upper;
    vec3 world_point, shape_point; /* the witnesses, rounded; one point when touching */
    uint32_t world_triangle, shape_triangle; /* the caller's ids */
} shape_distance_output;

/* A shape tree placed at shape_at against a world tree placed at world_at (either NULL: as
 * built), both answered as trees of their posed vertices: the minimum distance between
 * their triangles, 0 exactly when they touch. Walked over both trees at once, nearest
 * pair of nodes first; each triangle pair bounded by tri_distance.h's proof. Ties in
 * upper go to the smaller world triangle, then shape triangle; when they touch, the
 * answer is the first touching pair the walk meets (the walk is deterministic). The shape tree is best
 * built with octree_def.node_bounds (tighter boxes); any tree works. OCTREE_ERR_INVALID
 * for a pose octree_pose_check refuses or a NaN or negative max_distance. */
octree_status octree_shape_distance(const octree *world, const pose *world_at, const octree *shape,
                                    const pose *shape_at, double max_distance, shape_distance_output *out,
                                    query_stats *stats);

/* Clearance: *clear = 1 when every point of the placed shape is proven farther than radius
 * from the world, else 0 (some pair could not be proven beyond it: never 1 when the real
 * distance is <= radius). Stops at the first such pair. */
octree_status octree_shape_clearance(const octree *world, const pose *world_at, const octree *shape,
                                     const pose *shape_at, double radius, int *clear, query_stats *stats);

#endif
