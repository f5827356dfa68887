/* Triangle and mesh queries: the seed's query outline (descend into nodes whose box the
 * query triangle touches, gather leaf lists, test each candidate once in full). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../geom/box_geometry.h"
#include "../geom/predicates.h"
#include "../geom/tri_box.h"
#include "../geom/tri_tri.h"
#include "id_set.h"
#include "octree_internal.h"
#include "octree_modes.h"

typedef struct tri_entry {
    uint32_t node;
    box3 box;
} tri_entry;

/* Whether the descent enters a node: q, made ready once per query, touches the node's box
 * grown by the mode's slack (0 in exact mode), decided exactly. Every mode's tree has
 * exact membership, so a triangle the mode's final test accepts, which lies within the
 * slack of q (octree_modes.c), is in a node this enters. */
static int node_touched(tri_box_triangle *prepared, box3 box, double grow)
{
    if (grow > 0.0)
        box = (box3){{box.lo.x - grow, box.lo.y - grow, box.lo.z - grow},
                     {box.hi.x + grow, box.hi.y + grow, box.hi.z + grow}};
    return tri_box_overlap_prepared(prepared, box);
}

/* prepared: q made ready once per query for the exact test (exact mode only). */
static int triangles_touch(const octree *tree, const vec3 q[3], const tri_tri_query *prepared, const vec3 w[3],
                           accuracy_mode mode)
{
    switch (mode) {
    case ACCURACY_SEED:
        return tri_tri_overlap_seed(q, w, tree->seed_epsilon);
    case ACCURACY_FAST:
        return tri_tri_overlap_fast(q, w);
    case ACCURACY_EXACT:
        break;
    }
    return tri_tri_overlap_exact_query(prepared, w);
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Rewrites internal ids as (caller's id << 32 | internal id), sorted by the caller's id,
 * which is the order answers are reported in. */
static uint64_t *sort_by_original(const octree *tree, const uint32_t *ids, size_t n)
{
    uint64_t *keyed = malloc((n ? n : 1) * sizeof *keyed);
    if (!keyed)
        return NULL;
    for (size_t i = 0; i < n; i++)
        keyed[i] = (uint64_t)tree->original_id[ids[i]] << 32 | ids[i];
    qsort(keyed, n, sizeof *keyed, compare_u64);
    return keyed;
}

typedef struct id_list {
    uint32_t *items;
    size_t count, capacity;
} id_list;

static int id_list_push(id_list *l, uint32_t id)
{
    if (array_reserve((void **)&l->items, &l->capacity, l->count + 1, sizeof *l->items, 32) != 0)
        return -1;
    l->items[l->count++] = id;
    return 0;
}

#define NO_NODE UINT32_MAX

/* Exact mode, from a node q touches: while q's bounds reach a single child of an interior
 * node, that child is touched (see triangle_search) and needs no test, so the descent
 * takes it at once, as the stack would after pushing and popping it, counting the same
 * nodes. A query about a leaf's size crosses no split plane on most levels above its
 * leaves, so this saves the stack and the eight-way loop on most of its path. Returns the
 * node where the bounds straddle a split plane or a leaf is reached, or NO_NODE when the
 * one child reached holds no triangle (q touches none). */
static tri_entry single_child_descent(const octree *tree, box3 qb, tri_entry e, query_stats *stats)
{
    for (;;) {
        octree_node node = tree->nodes[e.node];
        if (node.count != NODE_INTERIOR)
            return e;
        vec3 c = octree_split_point(tree, e.box);
        unsigned reach = box_octants_reached(qb.lo, qb.hi, c);
        if (reach & (reach - 1))
            return e;
        int k = __builtin_ctz(reach);
        if (tree->nodes[node.first + (uint32_t)k].count == 0)
            return (tri_entry){NO_NODE, e.box};
        stats->nodes_visited++;
        e = (tri_entry){node.first + (uint32_t)k, box_child(e.box, c, box_octant_upper_bits[k])};
    }
}

/* Finds the world triangles q touches: stops at the first when stop_at_first, else appends
 * all of them (unsorted, internal ids) to hits. Returns OCTREE_OK or OCTREE_ERR_NOMEM.
 *
 * Every node on the stack is touched by q, exactly; in fast and seed mode its box grown
 * by the mode's slack is. A touched interior node classifies q's bounds (grown alike),
 * clipped to its box, against its split planes once: children those bounds miss are not
 * touched; in exact mode, when they reach a single child, q touches that child (the
 * touching point lies in the clipped bounds); when they reach several,
 * tri_box_children_proven settles most, and only the others need the full triangle-box
 * test.
 *
 * With triangle boxes, exact mode skips a candidate whose outward box is strictly apart
 * from q's: two closed triangles whose boxes do not meet share no point, so the exact test
 * would say no. The skip comes before the duplicate check, as it is cheaper than a set
 * insertion. Seed and fast mode never skip: their tests can say yes for triangles whose
 * boxes are apart (seed: within epsilon of each other, and a zero-area triangle touches
 * everything; fast: rounding at large offsets), so a skip would change their answers. */
/* Tests candidate `id` unless tested already, and records a contact: in *any, and in hits
 * unless the search stops at the first. Returns 1 when the search is over (that first
 * contact, or out of memory, which *st then says), else 0. Forced inline: it runs once per
 * candidate, and as a call it cost exact triangle queries a fifth of their time. */
static inline __attribute__((always_inline)) int take_candidate(const octree *tree, const vec3 q[3],
                                                              const tri_tri_query *prepared,
                                                              accuracy_mode mode, id_set *tested, uint32_t id,
                                                              int stop_at_first, id_list *hits, int *any,
                                                              octree_status *st, query_stats *stats,
                                                              const pose *placed)
{
    int fresh = id_set_insert(tested, id);
    if (fresh == 0)
        return 0;
    if (fresh < 0) {
        *st = OCTREE_ERR_NOMEM;
        return 1;
    }
    stats->candidates_tested++;
    vec3 w[3];
    octree_triangle_vertices(tree, id, w);
    if (placed)
        for (int k = 0; k < 3; k++)
            w[k] = octree_apply_pose(placed, w[k]);
    if (!triangles_touch(tree, q, prepared, w, mode))
        return 0;
    *any = 1;
    if (stop_at_first)
        return 1;
    if (id_list_push(hits, id) != 0) {
        *st = OCTREE_ERR_NOMEM;
        return 1;
    }
    return 0;
}

/* A query against a tree placed by a pose (octree_triangle_posed): the descent takes the
 * query taken into the tree's frame, widened by `grow`; the final tests take the world
 * query and the posed triangles. */
typedef struct posed_query {
    const pose *at;
    vec3 world[3];
    double grow;
} posed_query;

static octree_status triangle_search(const octree *tree, const vec3 q[3], accuracy_mode mode, int stop_at_first,
                                     id_list *hits, int *any, query_stats *stats, const posed_query *posed)
{
    /* Fast and seed mode descend into nodes within their slack of q (octree_modes.c), and
     * an infinite slack, or a seed query with no bounded reach (zero area, a sliver: it
     * may touch anything), tests every triangle. A posed query (exact mode) descends
     * within its own widening of the local q. */
    double grow = posed                   ? posed->grow
                  : mode == ACCURACY_FAST ? octree_fast_triangle_slack(tree, q)
                  : mode == ACCURACY_SEED ? octree_seed_triangle_slack(tree, q)
                                          : 0.0;
    /* The exact descent's shortcuts hold for q itself, not for a widened q. */
    const int exact_descent = mode == ACCURACY_EXACT && grow == 0.0;
    const vec3 *tested_q = posed ? posed->world : q;
    const pose *placed = posed ? posed->at : NULL;
    box3 qb = {vec3_min(vec3_min(q[0], q[1]), q[2]), vec3_max(vec3_max(q[0], q[1]), q[2])};
    /* The descent's bounds: q's, grown by the slack. */
    box3 reach_box = {vec3_sub(qb.lo, (vec3){grow, grow, grow}), vec3_add(qb.hi, (vec3){grow, grow, grow})};
    const triangle_box *boxes = mode == ACCURACY_EXACT ? tree->triangle_boxes : NULL;
    triangle_box qbox = {{0}, {0}};
    if (boxes)
        qbox = triangle_box_around(reach_box.lo, reach_box.hi, tree->world.lo);
    triangle_box_probe qprobe = triangle_box_probe_of(&qbox);
    /* The query's side of the exact test (its bounds, plane and projection) depends on q
     * alone: computed here once instead of once per candidate. */
    tri_tri_query prepared;
    tri_box_triangle prepared_box;
    if (mode == ACCURACY_EXACT)
        tri_tri_query_prepare(&prepared, tested_q);
    tri_box_prepare(&prepared_box, q);
    id_set tested;
    id_set_init(&tested);
    octree_status st = OCTREE_OK;
    *any = 0;

    /* Candidates outside the tree's lists: the slivers, which no slack bounds for a seed
     * query, nor for a fast sliver query (octree_modes.c), and every triangle when the
     * slack is infinite. */
    size_t extra = 0;
    if (mode == ACCURACY_SEED || (mode == ACCURACY_FAST && octree_is_sliver(q)) || !(grow < INFINITY))
        extra = grow < INFINITY ? tree->sliver_list_count : tree->triangle_count;
    for (size_t i = 0; i < extra; i++) {
        uint32_t id = grow < INFINITY ? octree_sliver_list(tree)[i] : (uint32_t)i;
        if (take_candidate(tree, tested_q, &prepared, mode, &tested, id, stop_at_first, hits, any, &st, stats,
                           placed))
            goto done;
    }
    if (!(grow < INFINITY))
        goto done;

    tri_entry stack[OCTREE_STACK_MAX];
    size_t top = 0;
    stats->nodes_visited++;
    if (node_touched(&prepared_box, tree->world, grow)) {
        tri_entry start = {0, tree->world};
        if (exact_descent)
            start = single_child_descent(tree, qb, start, stats);
        if (start.node != NO_NODE)
            stack[top++] = start;
    }
    while (top > 0) {
        tri_entry e = stack[--top];
        octree_node node = tree->nodes[e.node];
        if (node.count == NODE_INTERIOR) {
            box3 b = e.box;
            vec3 c = octree_split_point(tree, b);
            unsigned reach = box_octants_reached(reach_box.lo, reach_box.hi, c);
            /* Children known touched without the full test: in exact mode as the build
             * decides them; with a slack, those holding a vertex of q (the others' rule
             * needs q to touch the node itself, not its grown box). */
            unsigned known = exact_descent ? tri_box_children_proven(q, b, c, reach)
                                           : reach & box_octants_holding(q, b, c);
            const octree_node *kids = &tree->nodes[node.first];
            for (int k = 0; k < 8; k++) {
                if (!((reach >> k) & 1) || kids[k].count == 0)
                    continue;
                box3 cb = box_child(b, c, box_octant_upper_bits[k]);
                stats->nodes_visited++;
                if (((known >> k) & 1) || node_touched(&prepared_box, cb, grow))
                    stack[top++] = (tri_entry){node.first + (uint32_t)k, cb};
            }
            continue;
        }
        stats->leaves_visited++;
        for (uint32_t i = 0; i < node.count; i++) {
            uint32_t id = tree->leaf_items[node.first + i];
            if (boxes && triangle_box_probe_apart(&boxes[id], &qprobe))
                continue;
            if (take_candidate(tree, tested_q, &prepared, mode, &tested, id, stop_at_first, hits, any, &st, stats,
                               placed))
                goto done;
        }
    }
done:
    id_set_release(&tested);
    return st;
}

static int valid_mode(accuracy_mode mode)
{
    return mode == ACCURACY_EXACT || mode == ACCURACY_SEED || mode == ACCURACY_FAST;
}

/* A triangle query's answer: the search, then the contacts sorted by the caller's ids,
 * their segments between the world query and the (posed) world triangles. */
static octree_status triangle_answer(const octree *tree, const vec3 tri[3], tri_detail detail, accuracy_mode mode,
                                     tri_output *out, query_stats *stats, const posed_query *posed)
{
    uint64_t fallbacks_before = predicates_fallback_count();
    query_stats local = {0};
    id_list hits = {0};
    int any = 0;
    octree_status st = triangle_search(tree, tri, mode, detail == TRI_YESNO, &hits, &any, &local, posed);
    out->hit = any;
    out->count = 0;
    out->truncated = 0;
    uint64_t *sorted = NULL;
    if (st == OCTREE_OK && detail != TRI_YESNO && !(sorted = sort_by_original(tree, hits.items, hits.count)))
        st = OCTREE_ERR_NOMEM;
    if (sorted) {
        const vec3 *q = posed ? posed->world : tri;
        out->count = hits.count;
        size_t keep = hits.count < out->capacity ? hits.count : out->capacity;
        out->truncated = keep < hits.count;
        for (size_t i = 0; i < keep; i++) {
            tri_contact *c = &out->contacts[i];
            c->triangle = (uint32_t)(sorted[i] >> 32);
            c->p = c->q = (vec3){0, 0, 0};
            if (detail == TRI_SEGMENTS) {
                vec3 w[3];
                octree_triangle_vertices(tree, (uint32_t)sorted[i], w);
                if (posed)
                    for (int k = 0; k < 3; k++)
                        w[k] = octree_apply_pose(posed->at, w[k]);
                tri_tri_contact_segment(q, w, &c->p, &c->q);
            }
        }
        free(sorted);
    }
    free(hits.items);
    query_stats_finish(stats, &local, fallbacks_before, predicates_fallback_count());
    return st;
}

octree_status octree_triangle(const octree *tree, const vec3 tri[3], tri_detail detail, accuracy_mode mode,
                              tri_output *out, query_stats *stats)
{
    for (int k = 0; k < 3; k++)
        if (!vec3_is_finite(tri[k]))
            return OCTREE_ERR_NONFINITE;
    if (!valid_mode(mode) || (detail != TRI_YESNO && detail != TRI_IDS && detail != TRI_SEGMENTS))
        return OCTREE_ERR_INVALID;
    return triangle_answer(tree, tri, detail, mode, out, stats, NULL);
}

octree_status octree_triangle_posed(const octree *tree, const pose *at, const vec3 tri[3], tri_detail detail,
                                    accuracy_mode mode, tri_output *out, query_stats *stats)
{
    if (!tree || !at || !out)
        return OCTREE_ERR_INVALID;
    for (int k = 0; k < 3; k++)
        if (!vec3_is_finite(tri[k]))
            return OCTREE_ERR_NONFINITE;
    if (mode != ACCURACY_EXACT || (detail != TRI_YESNO && detail != TRI_IDS && detail != TRI_SEGMENTS))
        return OCTREE_ERR_INVALID;
    vec3 local_tri[3];
    double grow;
    octree_status st = octree_posed_triangle_setup(tree, at, tri, local_tri, &grow);
    if (st != OCTREE_OK)
        return st;
    posed_query posed = {at, {tri[0], tri[1], tri[2]}, grow};
    return triangle_answer(tree, local_tri, detail, mode, out, stats, &posed);
}

octree_status octree_mesh_check(const mesh_view *shape, const pose *at, accuracy_mode mode)
{
    if (!shape || !at || (shape->triangle_count && (!shape->indices || !shape->vertices)) || !valid_mode(mode))
        return OCTREE_ERR_INVALID;
    for (int k = 0; k < 9; k++)
        if (!isfinite(at->r[k]))
            return OCTREE_ERR_NONFINITE;
    if (!vec3_is_finite(at->t))
        return OCTREE_ERR_NONFINITE;
    for (size_t i = 0; i < 3 * shape->triangle_count; i++) {
        if (shape->indices[i] >= shape->vertex_count)
            return OCTREE_ERR_INDEX;
        if (!vec3_is_finite(shape->vertices[shape->indices[i]]))
            return OCTREE_ERR_NONFINITE;
    }
    return OCTREE_OK;
}

octree_status octree_mesh_per_triangle(const octree *tree, const void *shape, size_t triangle_count,
                                       octree_shape_triangle_fn triangle_of, const pose *at, int all_pairs,
                                       accuracy_mode mode, mesh_output *out, query_stats *stats)
{
    uint64_t fallbacks_before = predicates_fallback_count();
    query_stats local = {0};
    out->hit = 0;
    out->count = 0;
    out->truncated = 0;
    octree_status st = OCTREE_OK;
    id_list hits = {0};
    for (size_t i = 0; i < triangle_count && st == OCTREE_OK; i++) {
        /* The posed triangle is rounded to doubles once; every decision after that is
         * exact on those doubles. */
        vec3 local_tri[3], q[3];
        triangle_of(shape, i, local_tri);
        for (int k = 0; k < 3; k++)
            q[k] = octree_apply_pose(at, local_tri[k]);
        if (!vec3_is_finite(q[0]) || !vec3_is_finite(q[1]) || !vec3_is_finite(q[2])) {
            st = OCTREE_ERR_NONFINITE;
            break;
        }
        int any = 0;
        hits.count = 0;
        st = triangle_search(tree, q, mode, !all_pairs, &hits, &any, &local, NULL);
        if (!any)
            continue;
        out->hit = 1;
        if (!all_pairs)
            break;
        uint64_t *sorted = sort_by_original(tree, hits.items, hits.count);
        if (!sorted) {
            st = OCTREE_ERR_NOMEM;
            break;
        }
        for (size_t j = 0; j < hits.count; j++) {
            if (out->count < out->capacity)
                out->pairs[out->count] = (mesh_pair){(uint32_t)i, (uint32_t)(sorted[j] >> 32)};
            out->count++;
        }
        free(sorted);
    }
    out->truncated = out->count > out->capacity;
    free(hits.items);
    query_stats_finish(stats, &local, fallbacks_before, predicates_fallback_count());
    return st;
}
