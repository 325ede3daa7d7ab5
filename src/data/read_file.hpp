#pragma once
/// \file src/data/read_file.hpp
/// Internal to alphainv::data: the one bounded reader of the format files (dataset.json, run
/// CSVs, model.json). Not installed; not real-time safe.

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include "alphainv/error.hpp"

namespace alphainv::data_detail {

namespace fs = std::filesystem;

/// Reads a whole regular file, refusing files larger than `max_bytes` before allocating.
inline std::string read_file(const fs::path& path, std::uint64_t max_bytes) {
  const std::string name = path.string();
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (st.type() == fs::file_type::not_found) throw Error("file does not exist", name);
  if (ec) throw Error("cannot access the file: " + ec.message(), name);
  if (fs::is_directory(st)) throw Error("expected a file, found a folder", name);
  if (!fs::is_regular_file(st)) throw Error("expected a regular file", name);
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw Error("cannot read the file size: " + ec.message(), name);
  if (size > max_bytes) {
    throw Error("file is " + std::to_string(size) + " bytes; the limit is " +
                    std::to_string(max_bytes) + " bytes",
                name);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw Error(std::string("cannot open the file for reading: ") + std::strerror(errno), name);
  std::string text(static_cast<std::size_t>(size), '\0');
  in.read(text.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) {
    throw Error("read " + std::to_string(in.gcount()) + " bytes, expected " + std::to_string(size) +
                    " (did the file change while being read?)",
                name);
  }
  return text;
}

}  // namespace alphainv::data_detail
