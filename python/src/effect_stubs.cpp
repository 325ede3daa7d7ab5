/// \file effect_stubs.cpp
/// Build tool: writes the Python stubs (alphainv/__init__.pyi) from their template, with the
/// effect parameters and names taken from the effect table (kEffectCatalogue), so the stubs list
/// exactly what the module generates from it. Usage: alphainv_effect_stubs TEMPLATE OUTPUT.
///   a line "<indent># @EFFECT_PARAMETERS@" becomes one "<indent>name: float" line per parameter;
///   "@EFFECT_NAMES@" in a line becomes the quoted catalogue names, comma-separated.

#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>

#include "alphainv/model/effects.hpp"

int main(int argc, char** argv) {
  using namespace alphainv;
  if (argc != 3) {
    std::fprintf(stderr, "usage: alphainv_effect_stubs TEMPLATE OUTPUT\n");
    return 1;
  }
  std::ifstream in(argv[1]);
  if (!in) {
    std::fprintf(stderr, "alphainv_effect_stubs: cannot read %s\n", argv[1]);
    return 2;
  }
  std::string names;
  for (const EffectSpec& s : kEffectCatalogue) names += (names.empty() ? "\"" : ", \"") + std::string(s.name) + "\"";
  std::string out, line;
  while (std::getline(in, line)) {
    const std::size_t at = line.find("# @EFFECT_PARAMETERS@");
    if (at != std::string::npos) {
      const std::string indent = line.substr(0, at);
      for (const EffectSpec& s : kEffectCatalogue) {
        for (const EffectParameter& p : s) {
          out += indent + p.name + ": float  # " + p.description + " [" + p.unit + "] (" + s.name + ")\n";
        }
      }
      continue;
    }
    const std::size_t n = line.find("@EFFECT_NAMES@");
    if (n != std::string::npos) line.replace(n, 14, names);
    out += line + "\n";
  }
  std::ofstream o(argv[2], std::ios::trunc);
  o << out;
  if (!o.flush()) {
    std::fprintf(stderr, "alphainv_effect_stubs: cannot write %s\n", argv[2]);
    return 2;
  }
  return 0;
}
