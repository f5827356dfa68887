#include "logs_requests.h"

#include <math.h>
#include <string.h>

#include "channels.h"

static trioct_request_header_t header_of(const lr_req *q)
{
    trioct_request_header_t h = lw_header(q->client, q->id, q->reply, q->world);
    h.deadline_utime = q->deadline;
    return h;
}

static const char *channel_of(const lr_req *q, int kind)
{
    return q->channel != NULL ? q->channel : lw_channel(kind, q->world);
}

/* The old layout (ray_request_v1_t): every log made before contact existed was written in
 * it, and writing it still keeps those logs byte for byte. */
static trioct_ray_request_v1_t ray_message_v1(const lr_req *q, int8_t detail, int8_t accuracy, double tmin,
                                              double tmax, int32_t max_hits, int n, const trioct_vec3_t *origin,
                                              const trioct_vec3_t *direction)
{
    trioct_ray_request_v1_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.detail = detail;
    m.accuracy = accuracy;
    m.tmin = tmin;
    m.tmax = tmax;
    m.max_hits = max_hits;
    m.num_rays = n;
    m.origin = (trioct_vec3_t *)origin;
    m.direction = (trioct_vec3_t *)direction;
    return m;
}

void lr_rays(logs_writer *w, const lr_req *q, int8_t detail, int8_t accuracy, double tmin, double tmax,
             int32_t max_hits, int n, const trioct_vec3_t *origin, const trioct_vec3_t *direction)
{
    trioct_ray_request_v1_t m = ray_message_v1(q, detail, accuracy, tmin, tmax, max_hits, n, origin, direction);
    lw_ray_v1(w, channel_of(q, TRIOCT_CHANNEL_RAY), &m);
}

void lr_rays_contact(logs_writer *w, const lr_req *q, int8_t detail, int8_t accuracy, int8_t contact, double tmin,
                     double tmax, int32_t max_hits, int n, const trioct_vec3_t *origin,
                     const trioct_vec3_t *direction)
{
    trioct_ray_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.detail = detail;
    m.accuracy = accuracy;
    m.tmin = tmin;
    m.tmax = tmax;
    m.max_hits = max_hits;
    m.num_rays = n;
    m.origin = (trioct_vec3_t *)origin;
    m.direction = (trioct_vec3_t *)direction;
    m.contact = contact;
    lw_ray(w, channel_of(q, TRIOCT_CHANNEL_RAY), &m);
}

uint8_t *lr_encode_rays(const lr_req *q, int n, const trioct_vec3_t *origin, const trioct_vec3_t *direction,
                        size_t *size)
{
    trioct_ray_request_v1_t m = ray_message_v1(q, TRIOCT_RAY_REQUEST_T_CLOSEST, TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD,
                                               0, INFINITY, 1, n, origin, direction);
    return lw_encode_ray_v1(&m, size);
}

void lr_triangles(logs_writer *w, const lr_req *q, int8_t detail, int8_t accuracy, int n,
                  const trioct_triangle_t *triangles)
{
    trioct_triangle_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.detail = detail;
    m.accuracy = accuracy;
    m.num_triangles = n;
    m.triangles = (trioct_triangle_t *)triangles;
    lw_triangle(w, channel_of(q, TRIOCT_CHANNEL_TRI), &m);
}

void lr_mesh(logs_writer *w, const lr_req *q, int8_t detail, int8_t accuracy, const char *shape,
             int n_shape, const trioct_triangle_t *shape_triangles, int n_poses, const trioct_pose_t *poses)
{
    trioct_mesh_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.detail = detail;
    m.accuracy = accuracy;
    m.shape = (char *)(shape != NULL ? shape : "");
    m.num_shape_triangles = n_shape;
    m.shape_triangles = (trioct_triangle_t *)shape_triangles;
    m.num_poses = n_poses;
    m.poses = (trioct_pose_t *)poses;
    lw_mesh(w, channel_of(q, TRIOCT_CHANNEL_MESH), &m);
}

void lr_objects(logs_writer *w, const lr_req *q, int list, int n, const trioct_object_edit_t *edits)
{
    trioct_object_edit_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.list = (int8_t)list;
    m.num_edits = n;
    m.edits = (trioct_object_edit_t *)edits;
    lw_objects(w, channel_of(q, TRIOCT_CHANNEL_OBJECTS), &m);
}

/* The state request both forms share; the caller sets the rotations' form. */
static trioct_state_request_t state_message(const lr_req *q, int8_t detail, int8_t self_collision, int n_links,
                                            const trioct_state_link_t *links, int n_poses, const trioct_pose_t *poses)
{
    trioct_state_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.detail = detail;
    m.self_collision = self_collision;
    m.num_links = n_links;
    m.links = (trioct_state_link_t *)links;
    m.num_poses = n_poses;
    m.poses = (trioct_pose_t *)poses;
    return m;
}

void lr_state(logs_writer *w, const lr_req *q, int8_t detail, int8_t self_collision, int n_links,
              const trioct_state_link_t *links, int n_allowed, char **a, char **b, int n_poses,
              const trioct_pose_t *poses)
{
    trioct_state_request_t m = state_message(q, detail, self_collision, n_links, links, n_poses, poses);
    m.num_allowed = n_allowed;
    m.allowed_a = a;
    m.allowed_b = b;
    lw_state(w, channel_of(q, TRIOCT_CHANNEL_STATE), &m);
}

void lr_state_quaternions(logs_writer *w, const lr_req *q, int8_t detail, int8_t self_collision, int n_links,
                          const trioct_state_link_t *links, int n_poses, const trioct_pose_t *poses,
                          const double *quaternions)
{
    trioct_state_request_t m = state_message(q, detail, self_collision, n_links, links, n_poses, poses);
    m.rotation = TRIOCT_STATE_REQUEST_T_QUATERNION;
    m.num_quaternions = 4 * n_poses;
    m.quaternions = (double *)quaternions;
    lw_state(w, channel_of(q, TRIOCT_CHANNEL_STATE), &m);
}

void lr_distance_points(logs_writer *w, const lr_req *q, double within, int n, const trioct_vec3_t *points)
{
    trioct_distance_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.kind = TRIOCT_DISTANCE_REQUEST_T_POINTS;
    m.within = within;
    m.num_points = n;
    m.points = (trioct_vec3_t *)points;
    m.shape = "";
    lw_distance(w, channel_of(q, TRIOCT_CHANNEL_DISTANCE), &m);
}

void lr_distance_shape(logs_writer *w, const lr_req *q, int8_t kind, double within, const char *shape, int n_poses,
                       const trioct_pose_t *poses)
{
    trioct_distance_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.kind = kind;
    m.within = within;
    m.shape = (char *)shape;
    m.num_poses = n_poses;
    m.poses = (trioct_pose_t *)poses;
    lw_distance(w, channel_of(q, TRIOCT_CHANNEL_DISTANCE), &m);
}

void lr_load(logs_writer *w, const lr_req *q, const char *mesh_path, double resolution, int8_t accuracy,
             double seed_epsilon, int32_t effects)
{
    trioct_admin_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.op = TRIOCT_ADMIN_REQUEST_T_LOAD;
    m.mesh_path = (char *)mesh_path;
    m.resolution = resolution;
    m.accuracy = accuracy;
    m.seed_epsilon = seed_epsilon;
    m.effects = effects;
    lw_admin(w, q->channel != NULL ? q->channel : lw_channel(TRIOCT_CHANNEL_LOAD, LOGS_DAEMON), &m);
}

void lr_admin(logs_writer *w, const lr_req *q, int8_t op, const char *mesh_path)
{
    if (op == TRIOCT_ADMIN_REQUEST_T_LOAD) {
        lr_load(w, q, mesh_path, 0, TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD, 0, 0);
        return;
    }
    trioct_admin_request_t m;
    memset(&m, 0, sizeof m);
    m.header = header_of(q);
    m.op = op;
    m.mesh_path = (char *)(mesh_path != NULL ? mesh_path : "");
    m.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD;
    const char *channel = q->channel;
    if (channel == NULL)
        channel = op == TRIOCT_ADMIN_REQUEST_T_LIST ? lw_channel(TRIOCT_CHANNEL_LIST, "")
                                                    : lw_channel(TRIOCT_CHANNEL_ADMIN, q->world);
    lw_admin(w, channel, &m);
}

void lr_reload(logs_writer *w)
{
    /* The daemon reads only that the message came, signed. */
    lw_mark(w, lw_mark_channel(TRIOCT_MARK_RELOAD), "reload");
}

void lr_stop(logs_writer *w)
{
    /* Signed, as the reload mark. */
    lw_mark(w, lw_mark_channel(TRIOCT_MARK_STOP), "stop");
}
