// libtrioct from C++: the header is C inside extern "C"; a lambda without captures is a
// callback, and the user pointer carries the object it fills. The install test builds it
// against the installed library:
//
//     g++ ray_example.cpp $(pkg-config --cflags --libs trioct) -o ray_example_cpp
//
// Run: ray_example_cpp [WORLD [URL [TIMEOUT_MS]]]; exits as ray_example.c does.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "trioct.h"

namespace {

// What one request came back with, kept beyond the callback.
struct Outcome {
    int status = -1;
    std::string message;
    std::vector<trioct_ray_hit> hits;
};

using Client = std::unique_ptr<trioct_client, decltype(&trioct_disconnect)>;

} // namespace

int main(int argc, char **argv)
{
    const char *world = argc > 1 ? argv[1] : "yard";
    int timeout_ms = argc > 3 ? std::atoi(argv[3]) : 1000;
    trioct_connect_options opt{};
    opt.url = argc > 2 ? argv[2] : nullptr;
    int status = 0;
    char err[256];
    Client c(trioct_connect(&opt, &status, err, sizeof err), &trioct_disconnect);
    if (!c) {
        std::fprintf(stderr, "ray_example_cpp: %s\n", err);
        return 2;
    }

    std::vector<trioct_vec3> origins(8, trioct_vec3{0.0, 0.0, 10.0});
    std::vector<trioct_vec3> directions;
    for (int i = 0; i < 8; i++)
        directions.push_back(trioct_vec3{i - 4.0, 1.0, -8.0});
    trioct_ray_query q = trioct_ray_query_default(world);
    q.count = origins.size();
    q.origins = origins.data();
    q.directions = directions.data();

    Outcome out;
    auto done = [](trioct_client *, trioct_ray_result *res, void *user) {
        auto *o = static_cast<Outcome *>(user);
        o->status = res->reply.status;
        o->message = res->reply.message;
        o->hits.assign(res->hits, res->hits + res->num_hits);
    };
    if (trioct_rays_async(c.get(), &q, timeout_ms, done, &out, nullptr) != TRIOCT_OK) {
        std::fprintf(stderr, "rays: %s\n", trioct_last_error(c.get()));
        return 1;
    }
    while (trioct_in_flight(c.get()) > 0)
        if (trioct_poll(c.get(), -1) < 0)
            break;
    if (out.status != TRIOCT_OK) {
        std::fprintf(stderr, "rays: %s: %s\n", trioct_status_name(out.status), out.message.c_str());
        return 1;
    }
    std::printf("%zu hits\n", out.hits.size());
    return 0;
}
