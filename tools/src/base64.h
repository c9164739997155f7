#pragma once
// Base64 (RFC 4648, with padding), for the data: URIs that make `placedb report` one file.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace placedb::cli {

std::string base64Encode(const std::uint8_t* data, std::size_t size);
std::string base64Encode(const std::vector<std::uint8_t>& bytes);

}  // namespace placedb::cli
