// FCL 0.7 behind the C API of fcl_peer.h.
#include "fcl_peer.h"

#include <fcl/fcl.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>

#include <cstdio>
#include <exception>
#include <memory>
#include <vector>

using Model = fcl::BVHModel<fcl::OBBRSSd>;

struct fcl_peer_model {
    std::shared_ptr<Model> bvh;
    fcl::CollisionObjectd object;
    explicit fcl_peer_model(const std::shared_ptr<Model> &m) : bvh(m), object(m, fcl::Transform3d::Identity()) {}
};

extern "C" const char *fcl_peer_version(void)
{
    return FCL_VERSION;
}

extern "C" fcl_peer_model *fcl_peer_model_new(const double *xyz, size_t vertex_count, const uint32_t *indices,
                                              size_t triangle_count)
{
    try {
        std::vector<fcl::Vector3d> vertices(vertex_count);
        for (size_t i = 0; i < vertex_count; i++)
            vertices[i] = fcl::Vector3d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
        std::vector<fcl::Triangle> triangles(triangle_count);
        for (size_t i = 0; i < triangle_count; i++)
            triangles[i] = fcl::Triangle(indices[3 * i], indices[3 * i + 1], indices[3 * i + 2]);
        auto bvh = std::make_shared<Model>();
        if (bvh->beginModel((int)triangle_count, (int)vertex_count) != fcl::BVH_OK ||
            bvh->addSubModel(vertices, triangles) != fcl::BVH_OK || bvh->endModel() != fcl::BVH_OK) {
            std::fprintf(stderr, "fcl_peer: building the BVHModel failed\n");
            return nullptr;
        }
        bvh->computeLocalAABB();
        return new fcl_peer_model(bvh);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "fcl_peer: %s\n", e.what());
        return nullptr;
    }
}

extern "C" void fcl_peer_model_free(fcl_peer_model *model)
{
    delete model;
}

extern "C" size_t fcl_peer_collide(fcl_peer_model *shape, const double r[9], const double t[3],
                                   const fcl_peer_model *world, size_t max_contacts, uint32_t *world_ids,
                                   size_t id_cap)
{
    if (r && t) {
        fcl::Transform3d tf = fcl::Transform3d::Identity();
        fcl::Matrix3d rot;
        rot << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
        tf.linear() = rot;
        tf.translation() = fcl::Vector3d(t[0], t[1], t[2]);
        // What a planning scene does when a link moves: new transform, then its AABB.
        shape->object.setTransform(tf);
        shape->object.computeAABB();
    }
    fcl::CollisionRequestd request(max_contacts, false);
    fcl::CollisionResultd result;
    fcl::collide(&shape->object, &world->object, request, result);
    size_t n = result.numContacts();
    if (world_ids)
        for (size_t i = 0; i < n && i < id_cap; i++)
            world_ids[i] = (uint32_t)result.getContact(i).b2;
    return n;
}

struct fcl_peer_scene {
    std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects;
    fcl::DynamicAABBTreeCollisionManagerd manager;
};

namespace {
struct scene_query {
    const fcl::CollisionObjectd *skip;
    bool hit;
};

// The broadphase's narrow-phase callback, as MoveIt's: one fcl::collide per candidate
// pair, a single contact asked for, and true (stop) once one is found.
bool narrow_phase(fcl::CollisionObjectd *o1, fcl::CollisionObjectd *o2, void *data)
{
    auto *q = static_cast<scene_query *>(data);
    if (q->hit)
        return true;
    if (o1 == q->skip || o2 == q->skip)
        return false;
    fcl::CollisionRequestd request(1, false);
    fcl::CollisionResultd result;
    fcl::collide(o1, o2, request, result);
    q->hit = result.isCollision();
    return q->hit;
}

fcl::Transform3d transform_of(const double r[9], const double t[3])
{
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    fcl::Matrix3d rot;
    rot << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
    tf.linear() = rot;
    tf.translation() = fcl::Vector3d(t[0], t[1], t[2]);
    return tf;
}
} // namespace

extern "C" fcl_peer_scene *fcl_peer_scene_new(void)
{
    return new fcl_peer_scene();
}

extern "C" void fcl_peer_scene_add(fcl_peer_scene *scene, const fcl_peer_model *model, const double r[9],
                                   const double t[3])
{
    auto object = std::make_unique<fcl::CollisionObjectd>(model->bvh, transform_of(r, t));
    object->computeAABB();
    scene->manager.registerObject(object.get());
    scene->objects.push_back(std::move(object));
}

extern "C" void fcl_peer_scene_setup(fcl_peer_scene *scene)
{
    scene->manager.setup();
}

extern "C" int fcl_peer_scene_collide(fcl_peer_scene *scene, fcl_peer_model *link, const double r[9],
                                      const double t[3], long skip)
{
    link->object.setTransform(transform_of(r, t));
    link->object.computeAABB();
    scene_query q = {skip >= 0 ? scene->objects[(size_t)skip].get() : nullptr, false};
    scene->manager.collide(&link->object, &q, narrow_phase);
    return q.hit ? 1 : 0;
}

extern "C" void fcl_peer_scene_free(fcl_peer_scene *scene)
{
    delete scene;
}

extern "C" int fcl_peer_links_collide(const fcl_peer_model *a, const fcl_peer_model *b)
{
    if (!a->object.getAABB().overlap(b->object.getAABB()))
        return 0;
    fcl::CollisionRequestd request(1, false);
    fcl::CollisionResultd result;
    fcl::collide(&a->object, &b->object, request, result);
    return result.isCollision() ? 1 : 0;
}

extern "C" void fcl_peer_move(fcl_peer_model *link, const double r[9], const double t[3])
{
    link->object.setTransform(transform_of(r, t));
    link->object.computeAABB();
}

extern "C" double fcl_peer_point_distance(const fcl_peer_model *world, const double p[3], double nearest[3])
{
    // A point as FCL takes one: a sphere of radius 0, placed at p.
    static thread_local std::shared_ptr<fcl::Sphered> point = std::make_shared<fcl::Sphered>(0.0);
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    fcl::CollisionObjectd object(point, transform_of(identity, p));
    fcl::DistanceRequestd request(nearest != nullptr);
    fcl::DistanceResultd result;
    fcl::distance(&world->object, &object, request, result);
    if (nearest)
        for (int k = 0; k < 3; k++)
            nearest[k] = result.nearest_points[0][k];
    return result.min_distance;
}

extern "C" double fcl_peer_distance(fcl_peer_model *shape, const double r[9], const double t[3],
                                    const fcl_peer_model *world, double world_point[3], double shape_point[3])
{
    shape->object.setTransform(transform_of(r, t));
    shape->object.computeAABB();
    fcl::DistanceRequestd request(world_point != nullptr);
    fcl::DistanceResultd result;
    fcl::distance(&world->object, &shape->object, request, result);
    if (world_point)
        for (int k = 0; k < 3; k++) {
            world_point[k] = result.nearest_points[0][k];
            shape_point[k] = result.nearest_points[1][k];
        }
    return result.min_distance;
}
