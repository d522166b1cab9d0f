// `render --output-quantity illuminance` and `--work-plane`: the command line's side of
// render/illuminance.h (what to compute from the options, what to write and report).
#pragma once

#include "penumbra/methods/render.h"
#include "penumbra/render/illuminance.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace penumbra {

// Whether any lighting-design option is given (then illuminanceRequest checks them).
bool wantsIlluminance(const RenderOptions& options);

// The request from the options for a width x height view; refuses bad values and options that
// need another one (--false-colour without --output-quantity illuminance, --grid-* without
// --work-plane).
Expected<IlluminanceRequest> illuminanceRequest(const RenderOptions& options, int width,
                                                int height);

// Once the scene is loaded: a request for the scene's own calculation objects when the options
// asked for nothing (`lux` empty), then the request checked against the scene
// (checkIlluminanceRequest), before any work.
Status prepareIlluminance(std::optional<IlluminanceRequest>& lux, const RenderOptions& options,
                          const Scene& scene, int width, int height);

// With --output-quantity illuminance, the images: lux in every channel for .exr/.hdr/.pfm, and
// for .png the false-colour picture with its legend (--false-colour, --lux-max) or the lux
// tone-mapped in grey. Else `radiance` as usual. Then the grid's CSV (--grid-csv), and the
// figures into `stats` ("illuminance": {"work_plane": ..., "image": ...}) and the log.
Status writeRenderOutputs(const RenderOptions& options, const std::vector<std::string>& outputs,
                          const Image& radiance, const IlluminanceReport* report,
                          nlohmann::json* stats, const std::string& frame_name = "");

// The values a render gives back in memory (methods/run_context.h): lux in every channel with
// --output-quantity illuminance, else the radiance.
Image renderedValues(const RenderOptions& options, const Image& radiance,
                     const IlluminanceReport* report);

}  // namespace penumbra
