// The public API over a communicator (penumbra/penumbra_mpi.h), run under mpirun by
// tests/cluster/test_mpi.py: every rank makes the same calls; rank 0's results must equal those of
// the same calls on one process, the other ranks' must be empty, and bad options must throw on
// every rank without a collective left waiting. Exit code 0 when every check holds.
#include "penumbra/penumbra_mpi.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace api = penumbra::api;

namespace {

int g_rank = 0;
int g_failures = 0;

void expect(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "rank %d: FAILED: %s\n", g_rank, what);
  ++g_failures;
}

}  // namespace

int main(int argc, char** argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  try {
    expect(api::mpiAvailable(), "the library has MPI");
    const api::Communicator world = api::communicator(MPI_COMM_WORLD);
    const api::Scene scene = api::Scene::load("cornell");

    // The path tracer and matrix radiosity (Jacobi): rank 0 gets one process's image, bit for
    // bit; the other ranks nothing.
    const std::vector<std::vector<std::string>> renders = {
        {"--width", "40", "--height", "30", "--spp", "4", "--quiet"},
        {"--method", "matrix", "--solver", "jacobi", "--elements", "500", "--width", "40",
         "--height", "30", "--quiet"}};
    for (const std::vector<std::string>& options : renders) {
      const api::Result shared = api::render(world, scene, options);
      const api::Result alone = api::render(scene, options);  // this process alone
      if (g_rank == 0) {
        expect(shared.images.size() == 1 && alone.images.size() == 1, "one image on rank 0");
        expect(!shared.images.empty() && !alone.images.empty() &&
                   shared.images[0].rgb == alone.images[0].rgb,
               "rank 0's image is one process's, bit for bit");
      } else {
        expect(shared.images.empty(), "no image on the other ranks");
      }
    }

    // trace: rank 0's rays, from the box's middle in a spread of directions.
    std::vector<float> rays;
    if (g_rank == 0) {
      for (int i = 0; i < 5000; ++i) {
        const double z = 1.0 - 2.0 * (i + 0.5) / 5000.0, phi = i * 2.39996322972865332;
        const double r = std::sqrt(1.0 - z * z);
        rays.insert(rays.end(), {0.278f, 0.4f, 0.28f, 0.0f, float(r * std::cos(phi)),
                                 float(r * std::sin(phi)), float(z), 1e30f});
      }
    }
    const api::Hits shared = api::trace(world, scene, rays, {.device = "cpu"});
    const api::Hits alone = api::trace(scene, rays, {.device = "cpu"});
    if (g_rank == 0) {
      expect(shared.triangle.size() == 5000, "a hit per ray");
      expect(shared.triangle == alone.triangle && shared.t == alone.t && shared.u == alone.u &&
                 shared.v == alone.v,
             "rank 0's hits are one process's, in the rays' order");
      int hits = 0;
      for (int t : shared.triangle) hits += t >= 0;
      // The box is open at the front (where the camera is): the rays that way leave it.
      expect(hits > 3000 && hits < 5000, "rays hit the walls and leave through the front");
    } else {
      expect(shared.triangle.empty(), "no hits on the other ranks");
    }

    // Bad options: every rank throws the input error; none waits for the others.
    try {
      api::render(world, scene, {"--spp", "-3"});
      expect(false, "--spp -3 throws");
    } catch (const api::Error& e) {
      expect(e.kind() == api::ErrorKind::kInput, "--spp -3 is an input error");
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rank %d: FAILED: %s\n", g_rank, e.what());
    ++g_failures;
  }
  int all = 0;
  MPI_Allreduce(&g_failures, &all, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  if (g_rank == 0) std::printf("api over %d ranks: %d failed checks\n", size, all);
  MPI_Finalize();
  return all == 0 ? 0 : 1;
}
