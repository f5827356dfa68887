/* Requests of the replay logs in one line each: who asks (client, request id, reply
 * channel), about which world, on which channel (by default the world's channel of the
 * request's type, or for admin the channel its op is served on), with which deadline. */
#ifndef TRIOCT_LOGS_REQUESTS_H
#define TRIOCT_LOGS_REQUESTS_H

#include "logs_writer.h"

typedef struct lr_req {
    int64_t client;
    int64_t id;
    const char *reply;   /* reply channel */
    const char *world;   /* header.world, and the world of the default channel */
    const char *channel; /* NULL: the default */
    int64_t deadline;    /* 0: none */
} lr_req;

/* A ray request in ray_request_v1_t, the layout every log before the contact field was
 * made with (so those logs regenerate byte for byte); lr_rays_contact writes ray_request_t
 * with its contact. */
void lr_rays(logs_writer *w, const lr_req *q, int8_t detail, int8_t accuracy, double tmin, double tmax,
             int32_t max_hits, int n, const trioct_vec3_t *origin, const trioct_vec3_t *direction);
void lr_rays_contact(logs_writer *w, const lr_req *q, int8_t detail, int8_t accuracy, int8_t contact, double tmin,
                     double tmax, int32_t max_hits, int n, const trioct_vec3_t *origin,
                     const trioct_vec3_t *direction);
void lr_triangles(logs_writer *w, const lr_req *q, int8_t detail, int8_t accuracy, int n,
                  const trioct_triangle_t *triangles);
/* shape: a named shape, or NULL for the n_shape inline triangles. */
void lr_mesh(logs_writer *w, const lr_req *q, int8_t detail, int8_t accuracy, const char *shape,
             int n_shape, const trioct_triangle_t *shape_triangles, int n_poses, const trioct_pose_t *poses);
/* LIST, INFO, UNLOAD, or LOAD of mesh_path ("" for the scene's section) with the defaults. */
void lr_admin(logs_writer *w, const lr_req *q, int8_t op, const char *mesh_path);
/* An object edit list (n edits, maybe none) on the world's OBJECTS channel; list: the
 * reply lists the objects. */
void lr_objects(logs_writer *w, const lr_req *q, int list, int n, const trioct_object_edit_t *edits);
/* A state check of n_links links at n_poses poses (n_links per state), with n_allowed
 * pairs a[i]:b[i]. */
void lr_state(logs_writer *w, const lr_req *q, int8_t detail, int8_t self_collision, int n_links,
              const trioct_state_link_t *links, int n_allowed, char **a, char **b, int n_poses,
              const trioct_pose_t *poses);
/* The same with the rotations as quaternions (4 a pose, w x y z); poses[k].r unused. */
void lr_state_quaternions(logs_writer *w, const lr_req *q, int8_t detail, int8_t self_collision, int n_links,
                          const trioct_state_link_t *links, int n_poses, const trioct_pose_t *poses,
                          const double *quaternions);
/* Point distances: n points (none when 0), nothing farther than within (< 0: no limit). */
void lr_distance_points(logs_writer *w, const lr_req *q, double within, int n, const trioct_vec3_t *points);
/* A shape distance or clearance request (kind SHAPE or CLEAR) of a named shape at n poses. */
void lr_distance_shape(logs_writer *w, const lr_req *q, int8_t kind, double within, const char *shape, int n_poses,
                       const trioct_pose_t *poses);
/* A LOAD with every option. */
void lr_load(logs_writer *w, const lr_req *q, const char *mesh_path, double resolution, int8_t accuracy,
             double seed_epsilon, int32_t effects);
/* The mark at which an ordered daemon reloads its scene (TRIOCT_RELOAD_replayd). */
void lr_reload(logs_writer *w);
/* The mark at which an ordered daemon begins stopping (TRIOCT_STOP_replayd). */
void lr_stop(logs_writer *w);

/* The ray request as lr_rays would write it (ray_request_v1_t), encoded, for hostile
 * variations (caller frees). */
uint8_t *lr_encode_rays(const lr_req *q, int n, const trioct_vec3_t *origin, const trioct_vec3_t *direction,
                        size_t *size);

#endif
