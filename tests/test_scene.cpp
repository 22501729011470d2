// Scene loading: the shipped meshes, the OpenMesh formats, JSON scene files, cleaning (welding,
// degenerate faces, splits) and the error messages for bad input.
#include <gtest/gtest.h>
#include <unistd.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <type_traits>

#include "geometry/polygon.h"
#include "scene/scene.h"
#include "scratch_dir.h"
#include "util/error.h"

namespace photometria {
namespace {

namespace fs = std::filesystem;

const std::string kMeshes = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/";

// A fresh folder per test for fixture files, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ =
        test_scratch::fresh_dir("photometria_scene_" + std::string(info->test_suite_name()) + "_" + info->name() + "_");
  }
  ~TempDir() { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }

 private:
  fs::path dir_;
};

// Loads and expects an Error of `kind` whose message contains every part.
void expect_error(const std::string& path, ErrorKind kind, const std::vector<std::string>& parts,
                  const LoadOptions& options = {}) {
  try {
    load_scene(path, options);
    ADD_FAILURE() << "no error for " << path;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.kind(), kind) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << "message must be one line: " << what;
    for (const std::string& part : parts)
      EXPECT_NE(what.find(part), std::string::npos) << "'" << part << "' not in: " << what;
  }
}

Vec3 unit_normal(const Scene& s, int f) { return newell_vector(s.face_polygon(f)).normalized(); }
double area(const Scene& s, int f) { return polygon_area(s.face_polygon(f)); }

Vec3 centroid(const Scene& s, int f) {
  Vec3 c = Vec3::Zero();
  for (const Vec3& v : s.face_polygon(f)) c += v;
  return c / double(s.faces[size_t(f)].vertices.size());
}

int group_index(const Scene& s, const std::string& name) {
  const auto it = std::find(s.groups.begin(), s.groups.end(), name);
  EXPECT_NE(it, s.groups.end()) << "no group " << name;
  return int(it - s.groups.begin());
}

std::vector<int> faces_of_group(const Scene& s, const std::string& name) {
  const int g = group_index(s, name);
  std::vector<int> faces;
  for (size_t f = 0; f < s.faces.size(); ++f)
    if (s.faces[f].group == g) faces.push_back(int(f));
  return faces;
}

const Material& material(const Scene& s, const std::string& name) {
  const auto it =
      std::find_if(s.materials.begin(), s.materials.end(), [&](const Material& m) { return m.name == name; });
  if (it == s.materials.end()) throw std::runtime_error("no material " + name);
  return *it;
}

std::set<std::string> material_names(const Scene& s) {
  std::set<std::string> names;
  for (const Material& m : s.materials) names.insert(m.name);
  return names;
}

// Closed and consistently oriented: every directed edge once, and its reverse once.
bool closed_and_oriented(const Scene& s, const std::vector<int>& faces) {
  std::map<std::pair<int, int>, int> edges;
  for (int f : faces) {
    const auto& v = s.faces[size_t(f)].vertices;
    for (size_t i = 0; i < v.size(); ++i) ++edges[{v[i], v[(i + 1) % v.size()]}];
  }
  for (const auto& [e, n] : edges) {
    const auto reverse = edges.find({e.second, e.first});
    if (n != 1 || reverse == edges.end() || reverse->second != 1) return false;
  }
  return true;
}

std::vector<int> all_faces(const Scene& s) {
  std::vector<int> f(s.faces.size());
  for (size_t i = 0; i < f.size(); ++i) f[i] = int(i);
  return f;
}

void expect_rgb(const Rgb& actual, const Rgb& expected) {
  for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(actual[c], expected[c]) << "channel " << c;
}

// ----- shipped meshes ---------------------------------------------------------------------------

TEST(ShippedMeshes, CornellBox) {
  const Scene s = load_scene(kMeshes + "cornell_box.obj");
  const std::set<std::string> names = {"leftWall", "rightWall", "floor",   "ceiling",
                                       "backWall", "shortBox",  "tallBox", "light"};
  EXPECT_EQ(s.materials.size(), 8u);
  EXPECT_EQ(material_names(s), names);
  EXPECT_EQ(std::set<std::string>(s.groups.begin(), s.groups.end()), names);
  expect_rgb(material(s, "light").emission, Rgb(17, 12, 4));
  expect_rgb(material(s, "light").reflectance, Rgb::Constant(0.78));
  expect_rgb(material(s, "leftWall").reflectance, Rgb(0.63, 0.065, 0.05));
  expect_rgb(material(s, "floor").emission, Rgb::Zero());

  // 18 quads with their own 4 vertices each; 28 distinct positions.
  EXPECT_EQ(s.stats.input_vertices, 72);
  EXPECT_EQ(s.stats.input_faces, 18);
  EXPECT_EQ(s.stats.welded_vertices, 72 - 28);
  EXPECT_EQ(s.vertices.size(), 28u);
  EXPECT_EQ(s.stats.split_nonplanar, 1);  // the left wall
  EXPECT_EQ(s.stats.split_polygons, 0);
  EXPECT_EQ(s.stats.dropped_degenerate, 0);
  EXPECT_EQ(s.stats.missing_material_files, 0);
  ASSERT_EQ(s.faces.size(), 19u);

  const std::vector<int> left = faces_of_group(s, "leftWall");
  ASSERT_EQ(left.size(), 2u);
  EXPECT_EQ(s.faces[size_t(left[0])].vertices.size(), 3u);
  EXPECT_EQ(s.faces[size_t(left[0])].source_face, s.faces[size_t(left[1])].source_face);

  for (size_t f = 0; f < s.faces.size(); ++f) {
    const Polygon p = s.face_polygon(int(f));
    ASSERT_TRUE(p.size() == 3 || p.size() == 4);
    EXPECT_LE(planarity_deviation(p), 1e-9) << "face " << f;
    if (p.size() == 4) { EXPECT_TRUE(is_convex(p)) << "face " << f; }
  }
  // Room faces inward (towards the middle of the box), the light down.
  const Vec3 middle(0, 1, 0);
  for (const char* g : {"floor", "ceiling", "backWall", "leftWall", "rightWall"})
    for (int f : faces_of_group(s, g)) EXPECT_GT(unit_normal(s, f).dot(middle - centroid(s, f)), 0) << g;
  for (int f : faces_of_group(s, "light")) EXPECT_LT(unit_normal(s, f).y(), -0.999);
  // Box sides and tops face out of their box. (Their bottoms lie on the floor facing up, as in
  // the original data.)
  for (const char* g : {"shortBox", "tallBox"}) {
    const std::vector<int> faces = faces_of_group(s, g);
    Vec3 c = Vec3::Zero();
    for (int f : faces) c += centroid(s, f) / double(faces.size());
    for (int f : faces)
      if (centroid(s, f).y() > 1e-9) { EXPECT_GT(unit_normal(s, f).dot(centroid(s, f) - c), 0) << g << " face " << f; }
  }
}

TEST(ShippedMeshes, FurnaceCubeIsClosedAndFacesInward) {
  const Scene s = load_scene(kMeshes + "furnace_cube.obj");
  ASSERT_EQ(s.faces.size(), 6u);
  EXPECT_EQ(s.vertices.size(), 8u);
  EXPECT_TRUE(closed_and_oriented(s, all_faces(s)));
  EXPECT_NEAR(signed_volume(s, all_faces(s)), -1.0, 1e-12);  // inward
  for (int f = 0; f < 6; ++f) {
    EXPECT_EQ(s.faces[size_t(f)].vertices.size(), 4u);
    EXPECT_NEAR(area(s, f), 1.0, 1e-12);
    EXPECT_GT(unit_normal(s, f).dot((Vec3(0.5, 0.5, 0.5) - centroid(s, f)).normalized()), 0.999);
  }
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].name, "furnace");
  expect_rgb(s.materials[0].reflectance, Rgb::Constant(0.5));
  expect_rgb(s.materials[0].emission, Rgb::Constant(1.0));
}

TEST(ShippedMeshes, RoomWithTable) {
  const Scene s = load_scene(kMeshes + "room_with_table.obj");
  EXPECT_EQ(s.faces.size(), 37u);
  for (const Face& f : s.faces) EXPECT_EQ(f.vertices.size(), 4u);
  EXPECT_EQ(s.stats.split_nonplanar + s.stats.split_polygons + s.stats.dropped_degenerate, 0);
  expect_rgb(material(s, "wall").reflectance, Rgb::Constant(0.7));
  expect_rgb(material(s, "floor").reflectance, Rgb::Constant(0.5));
  expect_rgb(material(s, "light").emission, Rgb::Constant(10));
  expect_rgb(material(s, "light").reflectance, Rgb::Constant(0.8));

  std::vector<int> room = faces_of_group(s, "walls");
  for (const char* g : {"floor", "ceiling"})
    for (int f : faces_of_group(s, g)) room.push_back(f);
  EXPECT_EQ(room.size(), 6u);
  EXPECT_TRUE(closed_and_oriented(s, room));
  EXPECT_NEAR(signed_volume(s, room), -4.0 * 3.0 * 2.5, 1e-9);  // inward
  for (int f : room) EXPECT_GT(unit_normal(s, f).dot(Vec3(2, 1.25, 1.5) - centroid(s, f)), 0.999);

  const std::vector<int> light = faces_of_group(s, "light");
  ASSERT_EQ(light.size(), 1u);
  EXPECT_NEAR(area(s, light[0]), 0.64, 1e-12);
  EXPECT_NEAR(unit_normal(s, light[0]).y(), -1.0, 1e-12);
  EXPECT_NEAR(centroid(s, light[0]).y(), 2.499, 1e-12);

  // Slab and four legs: closed boxes facing outward, top surface at 0.75 m.
  const std::vector<int> table = faces_of_group(s, "table");
  EXPECT_EQ(table.size(), 30u);
  EXPECT_TRUE(closed_and_oriented(s, table));
  EXPECT_NEAR(signed_volume(s, table), 1.2 * 0.8 * 0.04 + 4 * 0.05 * 0.05 * 0.71, 1e-9);
  double top = 0;
  for (int f : table) top = std::max(top, centroid(s, f).y());
  EXPECT_NEAR(top, 0.75, 1e-12);
}

TEST(ShippedMeshes, TwoSquaresFaceEachOther) {
  const Scene s = load_scene(kMeshes + "two_squares.obj");
  ASSERT_EQ(s.faces.size(), 2u);
  const int bottom = faces_of_group(s, "bottom").at(0), top = faces_of_group(s, "top").at(0);
  EXPECT_NEAR(unit_normal(s, bottom).y(), 1.0, 1e-12);
  EXPECT_NEAR(unit_normal(s, top).y(), -1.0, 1e-12);
  EXPECT_NEAR(centroid(s, top).y() - centroid(s, bottom).y(), 1.0, 1e-12);
  EXPECT_NEAR(area(s, bottom) + area(s, top), 2.0, 1e-12);
  const Material& emitter = s.materials[size_t(s.faces[size_t(bottom)].material)];
  EXPECT_EQ(emitter.name, "emitter");
  expect_rgb(emitter.emission, Rgb::Constant(1));
  expect_rgb(emitter.reflectance, Rgb::Zero());
  expect_rgb(s.materials[size_t(s.faces[size_t(top)].material)].reflectance, Rgb::Constant(0.5));
}

// ----- OBJ details --------------------------------------------------------------------------------

const char* kSquare = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

TEST(ObjLoading, GroupsObjectsAndDefaultMaterial) {
  TempDir dir;
  const std::string path = dir.write("parts.obj", std::string(kSquare) +
                                                      "f 1 2 3\n"
                                                      "o thing\nf 1 3 4\n"
                                                      "g a b\nf -4 -3 -1\n");  // not a duplicate of f 1 3 4
  LoadOptions options;
  options.default_reflectance = Rgb(0.1, 0.2, 0.3);
  options.default_emission = Rgb::Constant(2);
  const Scene s = load_scene(path, options);
  EXPECT_EQ(s.groups, (std::vector<std::string>{"parts", "thing", "a b"}));
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].name, "default");
  expect_rgb(s.materials[0].reflectance, Rgb(0.1, 0.2, 0.3));
  expect_rgb(s.materials[0].emission, Rgb::Constant(2));
  ASSERT_EQ(s.faces.size(), 3u);
  for (int f = 0; f < 3; ++f) EXPECT_EQ(s.faces[size_t(f)].source_face, f);
  EXPECT_EQ(s.faces[2].vertices, (std::vector<int>{0, 1, 3}));  // relative indices
}

// A name that comes back later (g a, g b, g a) is the same group; many groups load in linear
// time (a CAD export with a `g` per face: the groups are looked up by name, not searched).
TEST(ObjLoading, RepeatedGroupNamesShareTheirGroup) {
  TempDir dir;
  std::string text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n";
  text += "g a\nf 1 2 3\ng b\nf 2 5 6\ng a\nf 1 3 4\n";
  for (int k = 0; k < 3000; ++k)
    text += "v " + std::to_string(k) + " 5 0\nv " + std::to_string(k + 1) + " 5 0\nv " + std::to_string(k) +
            " 6 0\ng part" + std::to_string(k) + "\nf -3 -2 -1\n";
  const Scene s = load_scene(dir.write("groups.obj", text));
  ASSERT_EQ(s.faces.size(), 3003u);
  ASSERT_EQ(s.groups.size(), 3002u);
  EXPECT_EQ(s.groups[0], "a");
  EXPECT_EQ(s.groups[1], "b");
  EXPECT_EQ(s.groups[2], "part0");
  EXPECT_EQ(s.groups[3001], "part2999");
  EXPECT_EQ(s.faces[0].group, 0);
  EXPECT_EQ(s.faces[1].group, 1);
  EXPECT_EQ(s.faces[2].group, 0);
  EXPECT_EQ(s.faces[3002].group, 3001);
}

TEST(ObjLoading, MissingMtlKeepsUsemtlNamesWithDefaults) {
  TempDir dir;
  const std::string path =
      dir.write("room.obj", std::string("mtllib nothere.mtl\n") + kSquare + "usemtl white\nf 1 2 3 4\n");
  const Scene s = load_scene(path);
  EXPECT_EQ(s.stats.missing_material_files, 1);
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].name, "white");
  expect_rgb(s.materials[0].reflectance, LoadOptions{}.default_reflectance);
}

TEST(ObjLoading, SingleKdValueIsGrey) {
  TempDir dir;
  dir.write("m.mtl", "newmtl grey\nKd 0.3\nKe 2\n");
  const Scene s = load_scene(dir.write("g.obj", std::string("mtllib m.mtl\n") + kSquare + "usemtl grey\nf 1 2 3 4\n"));
  expect_rgb(material(s, "grey").reflectance, Rgb::Constant(0.3));
  expect_rgb(material(s, "grey").emission, Rgb::Constant(2));
}

// ----- cleaning ---------------------------------------------------------------------------------

TEST(SceneCleaning, ZeroAreaFacesAreDroppedAndCounted) {
  TempDir dir;
  const std::string path = dir.write("degenerate.obj", std::string(kSquare) +
                                                           "v 1 0 0\n"  // 5: same place as 2
                                                           "v 2 0 0\n"  // 6: on the line through 1 and 2
                                                           "f 1 2 3 4\n"
                                                           "f 1 2 5\n"    // 1 2 2 after welding
                                                           "f 1 2 6\n");  // collinear
  const Scene s = load_scene(path);
  EXPECT_EQ(s.stats.input_faces, 3);
  EXPECT_EQ(s.stats.dropped_degenerate, 2);
  EXPECT_EQ(s.stats.welded_vertices, 1);
  ASSERT_EQ(s.faces.size(), 1u);
  EXPECT_EQ(s.faces[0].source_face, 0);
  EXPECT_EQ(s.vertices.size(), 4u);  // unused vertex 6 is gone
}

TEST(SceneCleaning, WeldToleranceIsRelativeToTheDiagonal) {
  TempDir dir;
  // Two unit squares sharing an edge through nearly coincident vertices (1e-12 apart).
  const std::string text = std::string(kSquare) +
                           "v 1.000000000001 0 0\nv 2 0 0\nv 2 1 0\nv 1 0.999999999999 0\n"
                           "f 1 2 3 4\nf 5 6 7 8\n";
  const std::string path = dir.write("two.obj", text);
  const Scene welded = load_scene(path);
  EXPECT_EQ(welded.stats.welded_vertices, 2);
  EXPECT_EQ(welded.vertices.size(), 6u);
  LoadOptions exact;
  exact.weld_tolerance = 0;
  const Scene apart = load_scene(path, exact);
  EXPECT_EQ(apart.stats.welded_vertices, 0);
  EXPECT_EQ(apart.vertices.size(), 8u);
}

TEST(SceneCleaning, SplitsPolygonsKeepingAreaAndOrientation) {
  TempDir dir;
  const std::string path = dir.write("polygons.obj",
                                     "v 0 0 0\nv 1 0 0\nv 1.3 1 0\nv 0.5 1.6 0\nv -0.3 1 0\n"  // convex pentagon
                                     "f 1 2 3 4 5\n"
                                     "v 0 0 1\nv 1 0.25 1\nv 2 0 1\nv 1 1 1\n"  // dart: vertex 7 is reflex
                                     "f 6 7 8 9\n"
                                     "v 0 0 2\nv 1 0 2\nv 1 1 2.1\nv 0 1 2\n"  // non-planar quad
                                     "f 10 11 12 13\n"
                                     "v 0 0 3\nv 1 0 3\nv 1 1 3.000000001\nv 0 1 3\n"  // planar within tolerance
                                     "f 14 15 16 17\n");
  const Scene s = load_scene(path);
  EXPECT_EQ(s.stats.split_polygons, 2);
  EXPECT_EQ(s.stats.split_nonplanar, 1);
  std::map<int, std::vector<int>> pieces;  // source face -> faces
  for (size_t f = 0; f < s.faces.size(); ++f) pieces[s.faces[f].source_face].push_back(int(f));
  ASSERT_EQ(pieces[0].size(), 3u);
  ASSERT_EQ(pieces[1].size(), 2u);
  ASSERT_EQ(pieces[2].size(), 2u);
  ASSERT_EQ(pieces[3].size(), 1u);
  EXPECT_EQ(s.faces[size_t(pieces[3][0])].vertices.size(), 4u);

  double pentagon = 0, dart = 0;
  for (int f : pieces[0]) pentagon += area(s, f);
  for (int f : pieces[1]) dart += area(s, f);
  const Polygon pent = {{0, 0, 0}, {1, 0, 0}, {1.3, 1, 0}, {0.5, 1.6, 0}, {-0.3, 1, 0}};
  EXPECT_NEAR(pentagon, polygon_area(pent), 1e-12);
  EXPECT_NEAR(dart, 0.75, 1e-12);
  for (int k = 0; k < 3; ++k)
    for (int f : pieces[k]) EXPECT_GT(unit_normal(s, f).z(), 0.99) << "source face " << k;
  // The non-planar quad is cut along its shorter diagonal, (1,0)-(0,1).
  for (int f : pieces[2]) {
    const Polygon p = s.face_polygon(f);
    EXPECT_NE(std::find(p.begin(), p.end(), Vec3(1, 0, 2)), p.end());
    EXPECT_NE(std::find(p.begin(), p.end(), Vec3(0, 1, 2)), p.end());
  }
}

// ----- OpenMesh formats ---------------------------------------------------------------------------

template <class Mesh>
Mesh unit_cube() {
  Mesh mesh;
  std::vector<typename Mesh::VertexHandle> v;
  for (int i = 0; i < 8; ++i)
    v.push_back(mesh.add_vertex(typename Mesh::Point(float(i & 1), float((i >> 1) & 1), float(i >> 2))));
  // Outward, counter-clockwise seen from outside.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    if constexpr (std::is_same_v<Mesh, OpenMesh::TriMesh_ArrayKernelT<>>) {
      mesh.add_face(v[size_t(q[0])], v[size_t(q[1])], v[size_t(q[2])]);
      mesh.add_face(v[size_t(q[0])], v[size_t(q[2])], v[size_t(q[3])]);
    } else {
      mesh.add_face(
          std::vector<typename Mesh::VertexHandle>{v[size_t(q[0])], v[size_t(q[1])], v[size_t(q[2])], v[size_t(q[3])]});
    }
  }
  return mesh;
}

void expect_unit_cube(const Scene& s, size_t faces, const std::string& stem) {
  EXPECT_EQ(s.faces.size(), faces);
  EXPECT_EQ(s.vertices.size(), 8u);
  EXPECT_TRUE(closed_and_oriented(s, all_faces(s)));
  EXPECT_NEAR(signed_volume(s, all_faces(s)), 1.0, 1e-12);
  EXPECT_EQ(s.groups, std::vector<std::string>{stem});
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].name, "default");
  expect_rgb(s.materials[0].reflectance, Rgb::Constant(0.25));
  expect_rgb(s.materials[0].emission, Rgb(1, 2, 3));
}

LoadOptions cube_options() {
  LoadOptions o;
  o.default_reflectance = Rgb::Constant(0.25);
  o.default_emission = Rgb(1, 2, 3);
  return o;
}

TEST(OpenMeshFormats, PolygonRoundTrip) {
  TempDir dir;
  const auto cube = unit_cube<OpenMesh::PolyMesh_ArrayKernelT<>>();
  for (const std::string ext : {"off", "ply", "om"}) {
    for (const bool binary : {false, true}) {
      if (ext == "om" && !binary) continue;  // .om is binary only
      const std::string path = dir.path(std::string(binary ? "bin_" : "txt_") + "cube." + ext);
      OpenMesh::IO::Options opts;
      if (binary) opts += OpenMesh::IO::Options::Binary;
      ASSERT_TRUE(OpenMesh::IO::write_mesh(cube, path, opts)) << path;
      SCOPED_TRACE(path);
      expect_unit_cube(load_scene(path, cube_options()), 6, fs::path(path).stem().string());
    }
  }
}

TEST(OpenMeshFormats, StlRoundTrip) {
  TempDir dir;
  const auto cube = unit_cube<OpenMesh::TriMesh_ArrayKernelT<>>();
  for (const bool binary : {false, true}) {
    const std::string path = dir.path(binary ? "bin_cube.stl" : "txt_cube.stl");
    OpenMesh::IO::Options opts;
    if (binary) opts += OpenMesh::IO::Options::Binary;
    ASSERT_TRUE(OpenMesh::IO::write_mesh(cube, path, opts));
    SCOPED_TRACE(path);
    const Scene s = load_scene(path, cube_options());
    expect_unit_cube(s, 12, fs::path(path).stem().string());
    EXPECT_EQ(s.stats.input_faces, 12);
  }
}

TEST(OpenMeshFormats, HandWrittenOffWithRepeatedVertexFace) {
  TempDir dir;
  // The second face repeats a vertex: OpenMesh drops it, we count it as degenerate.
  const std::string path = dir.write("square.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n3 0 1 1\n");
  const Scene s = load_scene(path);
  EXPECT_EQ(s.faces.size(), 1u);
  EXPECT_EQ(s.stats.input_faces, 2);
  EXPECT_EQ(s.stats.dropped_degenerate, 1);
  EXPECT_EQ(s.groups, std::vector<std::string>{"square"});
}

TEST(OpenMeshFormats, NonManifoldEdgeIsKept) {
  TempDir dir;
  // Three triangles on the edge 0-1: OpenMesh re-adds the third on duplicated vertices, which
  // welding merges back.
  const std::string path =
      dir.write("fin.off", "OFF\n5 3 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 -1 0\n3 0 1 2\n3 1 0 3\n3 0 1 4\n");
  const Scene s = load_scene(path);
  EXPECT_EQ(s.faces.size(), 3u);
  EXPECT_EQ(s.vertices.size(), 5u);
  EXPECT_EQ(s.stats.input_faces, 3);
}

// ----- JSON scene files ---------------------------------------------------------------------------

const char* kBoxOff =
    "OFF\n8 6 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n0 0 1\n1 0 1\n0 1 1\n1 1 1\n"
    "4 0 2 3 1\n4 4 5 7 6\n4 0 1 5 4\n4 2 6 7 3\n4 0 4 6 2\n4 1 3 7 5\n";

TEST(JsonScene, MeshesOverridesAndSettings) {
  TempDir dir;
  dir.write("box.off", kBoxOff);
  const std::string path = dir.write("scene.json", R"({
    // comments are allowed
    "meshes": [
      {"file": ")" + kMeshes + R"(two_squares.obj"},
      {"file": "box.off", "reflectance": 0.2, "emission": [0, 0, 0]}
    ],
    "materials": {
      "emitter": {"emission": [2, 3, 4]},
      "top": {"reflectance": [0.1, 0.2, 0.3]},
      "box": {"emission": 1}
    },
    "settings": {"max_edge": 0.25},
    "lights": [{"sphere": {"center": [0, 0, 3], "radius": 1, "intensity": 5}}]
  })");
  const Scene s = load_scene(path);
  EXPECT_EQ(s.source, path);
  EXPECT_EQ(s.groups, (std::vector<std::string>{"bottom", "top", "box"}));
  EXPECT_EQ(material_names(s), (std::set<std::string>{"emitter", "top", "box"}));  // "receiver" unused now
  expect_rgb(material(s, "emitter").emission, Rgb(2, 3, 4));
  expect_rgb(material(s, "emitter").reflectance, Rgb::Zero());
  expect_rgb(material(s, "top").reflectance, Rgb(0.1, 0.2, 0.3));
  expect_rgb(material(s, "top").emission, Rgb::Zero());
  expect_rgb(material(s, "box").reflectance, Rgb::Constant(0.2));  // the mesh entry's default
  expect_rgb(material(s, "box").emission, Rgb::Constant(1));
  EXPECT_EQ(s.stats.input_faces, 8);
  EXPECT_EQ(s.faces.size(), 8u);
  for (int f : faces_of_group(s, "box")) {
    EXPECT_GE(s.faces[size_t(f)].source_face, 2);
    EXPECT_EQ(s.materials[size_t(s.faces[size_t(f)].material)].name, "box");
  }
  EXPECT_EQ(s.settings.at("max_edge").get<double>(), 0.25);
  EXPECT_EQ(s.settings.at("lights").size(), 1u);
}

TEST(JsonScene, OverrideOfNameThatIsMaterialAndGroup) {
  TempDir dir;
  const std::string path =
      dir.write("cornell.json", R"({"meshes": [{"file": ")" + kMeshes +
                                    R"(cornell_box.obj"}], "materials": {"floor": {"reflectance": 0.3}}})");
  const Scene s = load_scene(path);
  EXPECT_EQ(s.materials.size(), 8u);
  expect_rgb(material(s, "floor").reflectance, Rgb::Constant(0.3));
}

TEST(JsonScene, Errors) {
  TempDir dir;
  dir.write("box.off", kBoxOff);
  expect_error(dir.write("syntax.json", "{\n  \"meshes\": [\n    {\"file\": \"box.off\",}\n  ]\n}\n"),
               ErrorKind::BadInput, {"syntax.json:3:"});
  expect_error(dir.write("key.json", R"({"mesh": []})"), ErrorKind::BadInput, {"key.json", "'mesh'"});
  expect_error(dir.write("entry.json", R"({"meshes": [{"fiel": "box.off"}]})"), ErrorKind::BadInput,
               {"entry.json", "'fiel'", "meshes[0]"});
  expect_error(
      dir.write("nomatch.json", R"({"meshes": [{"file": "box.off"}], "materials": {"nosuch": {"reflectance": 0.1}}})"),
      ErrorKind::BadInput, {"nomatch.json", "'nosuch'"});
  expect_error(dir.write("range.json",
                         R"({"meshes": [{"file": "box.off"}], "materials": {"box": {"reflectance": [1.5, 0, 0]}}})"),
               ErrorKind::BadInput, {"range.json", "reflectance 1.5 (channel 0)"});
  expect_error(dir.write("type.json", R"({"meshes": [{"file": "box.off", "reflectance": "red"}]})"),
               ErrorKind::BadInput, {"type.json", "meshes[0].reflectance"});
  expect_error(dir.write("missing.json", R"({"meshes": [{"file": "gone.obj"}]})"), ErrorKind::Io,
               {"gone.obj", "missing.json"});
  expect_error(dir.write("empty.json", R"({"meshes": []})"), ErrorKind::BadInput, {"empty.json", "meshes"});
}

// ----- bad input ----------------------------------------------------------------------------------

TEST(SceneBadInput, FilesAndExtensions) {
  TempDir dir;
  expect_error(dir.path("nothere.obj"), ErrorKind::Io, {"cannot open", "nothere.obj"});
  expect_error(dir.path("nothere.off"), ErrorKind::Io, {"cannot open", "nothere.off"});
  expect_error(dir.write("mesh.xyz", "whatever"), ErrorKind::BadInput, {"mesh.xyz", "'.xyz'"});
}

TEST(SceneBadInput, ObjLines) {
  TempDir dir;
  const std::string v3 = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  const struct {
    std::string text;
    std::vector<std::string> parts;
  } cases[] = {
      {"v 0 0 0\nv 1 abc 0\n", {"bad.obj:2:", "bad vertex coordinate 'abc'"}},
      {"\xEF\xBB\xBFv 0 0 0\r\nv 1 0 0\r\n\r\nv 0 x 0\r\n", {"bad.obj:4:", "'x'"}},  // BOM, CRLF
      {"v 0 0 0\rv 1 0 0\rv 0 x 0\r", {"bad.obj:3:", "'x'"}},                        // CR only
      {"v 0 0 nan\n", {"bad.obj:1:", "'nan'", "finite"}},
      {"\n\nv 0 -inf 0\n", {"bad.obj:3:", "'-inf'"}},
      {"v 0 0\n", {"bad.obj:1:", "3 coordinates"}},
      {v3 + "f 1 2 17\n", {"bad.obj:4:", "face index 17 out of range (3 vertices so far)"}},
      {v3 + "f 1 2 -4\n", {"bad.obj:4:", "face index -4 out of range"}},
      {"f 1 2 3\n" + v3, {"bad.obj:1:", "face index 1 out of range (0 vertices so far)"}},
      {v3 + "f 0 1 2\n", {"bad.obj:4:", "face index 0"}},
      {v3 + "f 1 2\n", {"bad.obj:4:", "f with 2 vertices"}},
      {v3 + "f 1/x 2 3\n", {"bad.obj:4:", "'1/x'"}},
      {v3 + "f 1//5 2 3\n", {"bad.obj:4:", "normal index 5 out of range"}},
      {"vn 0 0 x\n", {"bad.obj:1:", "bad normal value 'x'"}},
      {"vn 0 0 1\nvn 0 0 0\n", {"bad.obj:2:", "vn 0 0 0 has no direction"}},
      {v3 + "vn 0 -0 0.0\nf 1//1 2//1 3//1\n", {"bad.obj:4:", "vn 0 -0 0.0 has no direction"}},
      {"vn 1e300 1e300 0\n", {"bad.obj:1:", "vn 1e300 1e300 0 has no direction"}},  // length overflows
      {"vn 0 0 inf\n", {"bad.obj:1:", "'inf'", "finite"}},
      {"vn 0 0\n", {"bad.obj:1:", "vn needs 3 numbers, got 2"}},
      {"vt 0.5 y\n", {"bad.obj:1:", "'y'"}},
      {v3, {"bad.obj", "no faces"}},
      {v3 + "f 1 2 3 " +
           [] {
             std::string s;
             for (int i = 0; i < 300; ++i) s += "1 ";
             return s;
           }() +
           "\n",
       {"bad.obj:4:", "at most 255"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.text.substr(0, 60));
    expect_error(dir.write("bad.obj", c.text), ErrorKind::BadInput, c.parts);
  }
}

// OBJ vn are kept per corner (Face::corner_normals), normalised, in the corners' order: through
// welding (a repeated corner keeps the first one's vn), the split of a non-planar quad (each
// piece keeps its corners' vn) and --flip-normals (Face::reverse negates them); faces without vn
// have none.
TEST(ObjLoading, CornerNormalsFollowTheirCorners) {
  TempDir dir;
  const std::string path = dir.write("vn.obj",
                                     "v 0 0 0\nv 1 0 0\nv 1 1 0\n"             // triangle, no vn
                                     "v 0 0 1\nv 1 0 1\nv 1 1 1.3\nv 0 1 1\n"  // non-planar quad
                                     "v 0 0 2\nv 1 0 2\nv 1 0 2\nv 0 1 2\n"    // 9 and 10 coincide
                                     "vn 0 0 2\nvn 0 0.6 0.8\nvn 0.6 0 0.8\nvn -0.6 0 0.8\n"
                                     "f 1 2 3\n"
                                     "f 4//1 5//2 6//3 7//4\n"
                                     "f 8//1 9//2 10//3 11//4\n");  // welded: a triangle, 10's vn dropped
  // The vn given at each corner, told apart by x + 2y + 10z.
  const std::map<double, Vec3> quad_vn = {
      {10.0, {0, 0, 1}}, {11.0, {0, 0.6, 0.8}}, {16.0, {0.6, 0, 0.8}}, {12.0, {-0.6, 0, 0.8}}};
  const std::map<double, Vec3> welded_vn = {{20.0, {0, 0, 1}}, {21.0, {0, 0.6, 0.8}}, {22.0, {-0.6, 0, 0.8}}};
  for (const bool flip : {false, true}) {
    SCOPED_TRACE(flip ? "flipped" : "as read");
    LoadOptions o;
    o.flip_normals = flip;
    const Scene s = load_scene(path, o);
    ASSERT_EQ(s.faces.size(), 4u);
    EXPECT_EQ(s.stats.split_nonplanar, 1);
    int pieces = 0, welded = 0;
    for (const Face& f : s.faces) {
      if (f.source_face == 0) {
        EXPECT_TRUE(f.corner_normals.empty());
        continue;
      }
      ASSERT_EQ(f.corner_normals.size(), 3u);
      ++(f.source_face == 1 ? pieces : welded);
      for (size_t k = 0; k < 3; ++k) {
        const Vec3& p = s.vertices[size_t(f.vertices[k])];
        const Vec3 want = (f.source_face == 1 ? quad_vn : welded_vn).at(p.x() + 2 * p.y() + 10 * p.z());
        EXPECT_NEAR((f.corner_normals[k] - (flip ? -want : want)).norm(), 0.0, 1e-15) << p.transpose();
      }
    }
    EXPECT_EQ(pieces, 2);
    EXPECT_EQ(welded, 1);
  }
}

// A face that orientation fixing flips (wound against the rest of its closed surface) has its
// vn negated with it, corner by corner.
TEST(ObjLoading, CornerNormalsOfAFlippedFaceAreNegated) {
  TempDir dir;
  // A tetrahedron wound outward but for its slanted face (f 2 4 3 faces in, against the rest).
  const std::string path = dir.write("tetra.obj",
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                                     "vn 0 0 -1\nvn 0 -1 0\nvn -1 0 0\nvn -1 -2 -2\nvn -2 -1 -2\nvn -2 -2 -1\n"
                                     "f 1//1 3//1 2//1\nf 1//2 2//2 4//2\nf 1//3 4//3 3//3\n"
                                     "f 2//4 4//6 3//5\n");
  const Scene s = load_scene(path);
  EXPECT_EQ(s.stats.flipped_faces, 1);
  const std::map<double, Vec3> slanted_vn = {// by x + 2y + 3z, as the file gave them, then normalised
                                             {1.0, Vec3(-1, -2, -2) / 3},
                                             {2.0, Vec3(-2, -1, -2) / 3},
                                             {3.0, Vec3(-2, -2, -1) / 3}};
  int slanted = 0;
  for (const Face& f : s.faces) {
    ASSERT_EQ(f.corner_normals.size(), 3u);
    if (f.source_face != 3) continue;
    ++slanted;
    // Now wound outward: its vn (given pointing in, with the file's winding) point out.
    EXPECT_GT(newell_vector(s.face_polygon(3)).dot(Vec3(1, 1, 1)), 0.0);
    for (size_t k = 0; k < 3; ++k) {
      const Vec3& p = s.vertices[size_t(f.vertices[k])];
      EXPECT_NEAR((f.corner_normals[k] + slanted_vn.at(p.x() + 2 * p.y() + 3 * p.z())).norm(), 0.0, 1e-15)
          << p.transpose();
    }
  }
  EXPECT_EQ(slanted, 1);
}

TEST(SceneBadInput, MtlValues) {
  TempDir dir;
  const std::string obj = std::string("mtllib m.mtl\n") + kSquare + "usemtl white\nf 1 2 3 4\n";
  const std::string path = dir.write("box.obj", obj);
  const struct {
    std::string mtl;
    std::vector<std::string> parts;
  } cases[] = {
      {"newmtl white\n\nKd 0.5 abc 0.5\n", {"m.mtl:3:", "bad Kd value 'abc'"}},
      {"newmtl white\nKd 0.5 0.5\n", {"m.mtl:2:", "Kd needs 1 or 3 numbers, got 2"}},
      {"newmtl white\nKe nan 0 0\n", {"m.mtl:2:", "'nan'"}},
      {"# white\nnewmtl white\nKd 1.2 0.5 0.5\n",
       {"m.mtl:2:", "material 'white': reflectance 1.2 (channel 0) must be in [0, 1)"}},
      {"newmtl white\nKd 0.5 0.5 1\n", {"m.mtl:1:", "reflectance 1 (channel 2)"}},
      {"newmtl white\nKd 0.5 0.5 0.5\nKe 1 -1 1\n", {"m.mtl:1:", "emission -1 (channel 1) must be finite and >= 0"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.mtl);
    dir.write("m.mtl", c.mtl);
    expect_error(path, ErrorKind::BadInput, c.parts);
  }
}

TEST(SceneBadInput, DefaultMaterialOutOfRange) {
  TempDir dir;
  LoadOptions options;
  options.default_reflectance = Rgb::Constant(1.0);
  expect_error(dir.write("box.off", kBoxOff), ErrorKind::BadInput, {"box.off", "material 'default'", "reflectance 1"},
               options);
}

TEST(SceneBadInput, OpenMeshTextFormats) {
  TempDir dir;
  expect_error(dir.write("nan.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n"), ErrorKind::BadInput,
               {"nan.off:4:", "vertex 1 coordinate 'nan'"});
  expect_error(dir.write("index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n"), ErrorKind::BadInput,
               {"index.off:6:", "face index 9 out of range (3 vertices)"});
  expect_error(dir.write("short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n"), ErrorKind::BadInput, {"short.off", "ends early"});
  expect_error(dir.write("comment.off", "OFF\n# made by hand\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
               ErrorKind::BadInput, {"comment.off:2:", "comments"});
  expect_error(dir.write("nofaces.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n"), ErrorKind::BadInput,
               {"nofaces.off", "no faces"});
  const std::string ply_header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  expect_error(dir.write("nan.ply", ply_header + "0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n"), ErrorKind::BadInput,
               {"nan.ply:12:", "vertex 2 coordinate 'inf'"});
  expect_error(dir.write("index.ply", ply_header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"), ErrorKind::BadInput,
               {"index.ply:13:", "face index 3 out of range"});
  expect_error(dir.write("inf.stl",
                         "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                         "vertex 0 1 inf\nendloop\nendfacet\nendsolid t\n"),
               ErrorKind::BadInput, {"inf.stl:6:", "'inf'"});
}

TEST(SceneBadInput, NonFiniteVertexInBinaryMesh) {
  TempDir dir;
  auto cube = unit_cube<OpenMesh::PolyMesh_ArrayKernelT<>>();
  cube.set_point(OpenMesh::VertexHandle(3), OpenMesh::Vec3f(1, std::nanf(""), 0));
  const std::string path = dir.path("nan.om");
  ASSERT_TRUE(OpenMesh::IO::write_mesh(cube, path));
  expect_error(path, ErrorKind::BadInput, {"nan.om", "vertex 3", "non-finite"});
}

}  // namespace
}  // namespace photometria
