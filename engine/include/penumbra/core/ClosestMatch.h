#pragma once
// "Did you mean" suggestions for misspelt names: config keys, plugin parameters,
// technique names, the viewer's script commands.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::core {

// Levenshtein distance: insertions, deletions and substitutions each cost 1.
size_t editDistance(std::string_view a, std::string_view b);

// The candidate closest to `word` when it is within `maxDistance` edits (a likely typo),
// else an empty string. Ties go to the earlier candidate.
std::string closestMatch(std::string_view word, const std::vector<std::string>& candidates, size_t maxDistance = 2);

} // namespace penumbra::core
