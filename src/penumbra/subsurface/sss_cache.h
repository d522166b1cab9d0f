// The subsurface links on disk: building them is the method's one slow step (sec. 4.2.1:
// "precomputation of the links ... took approximately nine seconds"), and they depend only on
// the geometry, the atlas, the media and the link options, so a second run over the same scene
// reads them back. The file is keyed by a fingerprint of everything the links depend on (the
// link tree with its node positions, areas, radii, children and texel axes, the media, the
// options, the format version); a file that does not match, or is damaged, is ignored and
// rebuilt. Files are written whole (a temporary renamed into place).
//
// Layout, little-endian: "PENUMBRA-SSSLNK2" (16 bytes), fingerprint (u64), elements (u64), links
// per element (u32), nodes (u64), then elements x L node indices (u32) and elements x L factors
// (3 x f32), then elements x L offsets (3 x f32).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/subsurface/sss_links.h"

#include <cstdint>
#include <optional>
#include <span>
#include <string>

namespace penumbra {

// $PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra, else $HOME/.cache/penumbra (empty when
// none is set).
std::string defaultCacheDirectory();

uint64_t sssLinksFingerprint(const SssTree& tree, std::span<const Dipole> media,
                             const SssLinkOptions& options);

// The cached links for `fingerprint` in `directory`, if a matching, intact file is there.
std::optional<SssLinks> readCachedSssLinks(const std::string& directory, uint64_t fingerprint,
                                           const SssTree& tree);
// Writes them (creating the directory); an error says why it could not.
Status writeCachedSssLinks(const std::string& directory, uint64_t fingerprint, const SssTree& tree,
                           const SssLinks& links);

}  // namespace penumbra
