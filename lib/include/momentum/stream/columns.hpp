#pragma once
// Column lists as users write them: "t,q1-6,dq1-6" (a trailing "<first>-<last>" on a name is a
// range of joint numbers), and the joint columns of the stream format (q<j>, dq<j>, ...).

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace momentum::stream {

// Expands "t,q1-3" to {"t","q1","q2","q3"}. Throws momentum::Error on an empty item or a
// backwards range.
std::vector<std::string> expand_column_list(std::string_view list);

// Indices of `wanted` in `columns`; throws momentum::Error `where: missing column 'x'`.
std::vector<std::size_t> column_indices(const std::vector<std::string>& columns,
                                        const std::vector<std::string>& wanted,
                                        const std::string& where);

// Number of joints n such that prefix1..prefixn are all present (0 if prefix1 is absent).
std::size_t count_joint_columns(const std::vector<std::string>& columns, std::string_view prefix);

// {prefix1, ..., prefixn}.
std::vector<std::string> joint_columns(std::string_view prefix, std::size_t n);

}  // namespace momentum::stream
