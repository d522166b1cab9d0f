// Penumbra over MPI (docs/scaling.md): the communicator a call of penumbra.h runs over, from an
// MPI_Comm. Installed with a build that has MPI; the caller compiles and links against the same
// MPI (find_package(MPI) or mpicxx).
//
//   MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
//   const penumbra::api::Scene scene = penumbra::api::Scene::load("cornell");
//   penumbra::api::Result r =
//       penumbra::api::render(penumbra::api::communicator(MPI_COMM_WORLD), scene, {"--spp", "64"});
//   // rank 0: r.images[0]; the other ranks: an empty result
#pragma once

#include <mpi.h>
#include <penumbra/penumbra.h>

namespace penumbra::api {

inline Communicator communicator(MPI_Comm comm) {
  return Communicator{int64_t(MPI_Comm_c2f(comm))};
}

}  // namespace penumbra::api
