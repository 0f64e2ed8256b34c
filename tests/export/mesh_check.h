// What MeshLab's "Compute Topological Measures" reports, computed the same
// way for the tests: connected components, boundary edges (an edge of one
// triangle only), holes (closed loops of boundary edges), non-manifold edges
// (more than two triangles), edges two neighbours traverse the same way
// (inconsistent winding) and unreferenced vertices. A mesh is watertight
// when it has no boundary and no non-manifold edge. Also a small PLY reader
// (ASCII and binary little-endian) that checks the header as strictly as the
// tests need, independent of the writer.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace oslam::testing {

struct Topology {
  int components = 0;
  int boundary_edges = 0;
  int holes = 0;
  int non_manifold_edges = 0;
  int inconsistent_edges = 0;
  int unreferenced_vertices = 0;
  bool Watertight() const { return boundary_edges == 0 && non_manifold_edges == 0; }
};

inline int Find(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

inline Topology AnalyzeTopology(size_t num_vertices,
                                const std::vector<std::array<uint32_t, 3>>& triangles) {
  Topology topology;
  std::map<std::pair<uint32_t, uint32_t>, std::pair<int, int>> edges;  // (a<b) -> (uses, a->b uses)
  std::vector<int> parent(num_vertices);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<bool> used(num_vertices, false);
  for (const auto& t : triangles) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      used[a] = true;
      auto& e = edges[{std::min(a, b), std::max(a, b)}];
      ++e.first;
      if (a < b) ++e.second;
      parent[Find(parent, static_cast<int>(a))] = Find(parent, static_cast<int>(b));
    }
  }
  std::map<uint32_t, std::vector<uint32_t>> boundary;  // vertex -> boundary neighbours
  for (const auto& [key, e] : edges) {
    if (e.first == 1) {
      ++topology.boundary_edges;
      boundary[key.first].push_back(key.second);
      boundary[key.second].push_back(key.first);
    }
    if (e.first > 2) ++topology.non_manifold_edges;
    if (e.first == 2 && e.second != 1) ++topology.inconsistent_edges;
  }
  for (size_t v = 0; v < num_vertices; ++v) {
    if (!used[v])
      ++topology.unreferenced_vertices;
    else if (Find(parent, static_cast<int>(v)) == static_cast<int>(v))
      ++topology.components;
  }
  // Holes: connected groups of boundary edges.
  std::map<uint32_t, bool> seen;
  for (const auto& [start, neighbours] : boundary) {
    if (seen[start]) continue;
    ++topology.holes;
    std::vector<uint32_t> stack = {start};
    while (!stack.empty()) {
      const uint32_t v = stack.back();
      stack.pop_back();
      if (seen[v]) continue;
      seen[v] = true;
      for (const uint32_t w : boundary[v]) stack.push_back(w);
    }
  }
  return topology;
}

// Merges vertices at exactly the same position (what a renderer's split
// vertices hide), so a split mesh's closedness can be checked.
inline std::vector<std::array<uint32_t, 3>> WeldByPosition(
    const std::vector<Eigen::Vector3f>& positions, const std::vector<uint32_t>& indices,
    size_t* num_welded) {
  std::map<std::array<float, 3>, uint32_t> index_of;
  std::vector<uint32_t> welded(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) {
    const std::array<float, 3> key = {positions[i].x(), positions[i].y(), positions[i].z()};
    welded[i] = index_of.emplace(key, static_cast<uint32_t>(index_of.size())).first->second;
  }
  *num_welded = index_of.size();
  std::vector<std::array<uint32_t, 3>> triangles;
  for (size_t t = 0; t + 2 < indices.size(); t += 3)
    triangles.push_back({welded[indices[t]], welded[indices[t + 1]], welded[indices[t + 2]]});
  return triangles;
}

struct PlyFile {
  std::vector<std::string> header;  // every line up to and including end_header
  std::string format;               // "ascii" or "binary_little_endian"
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<uint8_t, 4>> rgba;
  std::vector<std::array<uint32_t, 3>> faces;
  std::vector<std::array<uint32_t, 2>> edges;
  std::string error;  // empty when the file parsed
};

// Reads the vertex layout the writer declares (x y z float, red green blue
// alpha uchar), faces as "list uchar int vertex_indices" and edges as
// "int vertex1, int vertex2"; anything else is an error.
inline PlyFile ReadPly(const std::string& path) {
  PlyFile ply;
  std::ifstream in(path, std::ios::binary);
  std::string line;
  size_t vertices = 0, faces = 0, edges = 0;
  std::string element;
  std::vector<std::string> vertex_properties;
  while (std::getline(in, line)) {
    ply.header.push_back(line);
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "format") {
      words >> ply.format;
    } else if (word == "element") {
      size_t count = 0;
      words >> element >> count;
      if (element == "vertex")
        vertices = count;
      else if (element == "face")
        faces = count;
      else if (element == "edge")
        edges = count;
      else
        ply.error = "unexpected element " + element;
    } else if (word == "property" && element == "vertex") {
      std::string type, name;
      words >> type >> name;
      vertex_properties.push_back(type + " " + name);
    } else if (word == "end_header") {
      break;
    }
  }
  const std::vector<std::string> expected = {"float x",     "float y",    "float z",    "uchar red",
                                             "uchar green", "uchar blue", "uchar alpha"};
  if (vertex_properties != expected) ply.error = "unexpected vertex properties";
  if (!ply.error.empty()) return ply;
  const bool binary = ply.format == "binary_little_endian";
  if (!binary && ply.format != "ascii") {
    ply.error = "unknown format " + ply.format;
    return ply;
  }
  for (size_t i = 0; i < vertices; ++i) {
    Eigen::Vector3f p;
    std::array<uint8_t, 4> c{};
    if (binary) {
      in.read(reinterpret_cast<char*>(p.data()), 12);
      in.read(reinterpret_cast<char*>(c.data()), 4);
    } else {
      int r, g, b, a;
      in >> p.x() >> p.y() >> p.z() >> r >> g >> b >> a;
      c = {static_cast<uint8_t>(r), static_cast<uint8_t>(g), static_cast<uint8_t>(b),
           static_cast<uint8_t>(a)};
    }
    ply.positions.push_back(p);
    ply.rgba.push_back(c);
  }
  auto read_int = [&](int32_t* value) {
    if (binary)
      in.read(reinterpret_cast<char*>(value), 4);
    else
      in >> *value;
  };
  for (size_t i = 0; i < faces; ++i) {
    int count = 0;
    if (binary) {
      uint8_t n = 0;
      in.read(reinterpret_cast<char*>(&n), 1);
      count = n;
    } else {
      in >> count;
    }
    if (count != 3) {
      ply.error = "face " + std::to_string(i) + " is not a triangle";
      return ply;
    }
    std::array<int32_t, 3> f{};
    for (int32_t& v : f) read_int(&v);
    ply.faces.push_back(
        {static_cast<uint32_t>(f[0]), static_cast<uint32_t>(f[1]), static_cast<uint32_t>(f[2])});
  }
  for (size_t i = 0; i < edges; ++i) {
    std::array<int32_t, 2> e{};
    for (int32_t& v : e) read_int(&v);
    ply.edges.push_back({static_cast<uint32_t>(e[0]), static_cast<uint32_t>(e[1])});
  }
  if (!in) ply.error = "file ends early";
  // Nothing may follow the data.
  else if (in.peek() != std::char_traits<char>::eof() && binary)
    ply.error = "bytes after the data";
  return ply;
}

}  // namespace oslam::testing
