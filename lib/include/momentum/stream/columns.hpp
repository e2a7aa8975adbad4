#pragma once
// Column lists as users write them: "t,q1-6,dq1-6" (a trailing "<first>-<last>" on a name is a
// range of joint numbers), and the joint columns of the stream format (q<j>, dq<j>, ...).

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace momentum::stream {

// The most columns a column list may name once its ranges are expanded. A CSV row of n
// columns takes at least 2n bytes and the reader refuses lines above 1 MiB, so no stream
// has more than 524,288 columns; a list is for selecting among real ones, and 65,536 names
// (a few MB) bound what a typo such as "q1-20000000" can allocate.
inline constexpr std::size_t kMaxListedColumns = 65536;

// Expands "t,q1-3" to {"t","q1","q2","q3"}. Throws momentum::Error on an empty item, a
// backwards range, or a list that would name more than kMaxListedColumns columns (checked
// before anything is allocated for it).
std::vector<std::string> expand_column_list(std::string_view list);

// The first name that occurs twice in `names`, or nullopt when all differ.
std::optional<std::string> first_duplicate(const std::vector<std::string>& names);

// "where: missing column 'x'", and when `columns` is a single other column, what it was (a
// header whose separator the reader did not recognize).
std::string missing_column_message(const std::vector<std::string>& columns, std::string_view name,
                                   const std::string& where);

// Indices of `wanted` in `columns`; throws momentum::Error with missing_column_message.
std::vector<std::size_t> column_indices(const std::vector<std::string>& columns,
                                        const std::vector<std::string>& wanted,
                                        const std::string& where);

// When the joint columns of `columns` are numbered from 0 (q0, dq0, ddq0, i0 or tau_m0), the
// --rename text that numbers them from 1 as the suite does ("q0..5=q1..6,dq0..5=dq1..6"), else
// empty.
std::string zero_based_joint_rename(const std::vector<std::string>& columns);

// "the stream's joint columns are numbered from 0 (q0..5, dq0..5): ..." with the --rename that
// fixes it, or empty when they are not (zero_based_joint_rename).
std::string zero_based_joint_message(const std::vector<std::string>& columns);

// Number of joints n such that prefix1..prefixn are all present (0 if prefix1 is absent).
std::size_t count_joint_columns(const std::vector<std::string>& columns, std::string_view prefix);

// {prefix1, ..., prefixn}.
std::vector<std::string> joint_columns(std::string_view prefix, std::size_t n);

}  // namespace momentum::stream
