#pragma once

// CSV as RFC 4180 writes it, for the tables pano4d writes (bench datasets,
// sweep collect): a field is quoted when it holds a comma, a quote or a
// line break, and a quote inside is doubled, so that spreadsheets and
// pandas read error messages back as they were.

#include <string>
#include <string_view>
#include <vector>

namespace pano4d {

std::string CsvField(std::string_view text);

// The fields, each through CsvField, joined by commas and ended by "\n".
std::string CsvRow(const std::vector<std::string>& fields);

}  // namespace pano4d
