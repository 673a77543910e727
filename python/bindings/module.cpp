// mac_registration._mac: the Python module over the ROS-free core, the parameter table and the PCL front
// end (python/mac_registration/__init__.py re-exports it). numpy arrays in, numpy arrays out; the GIL is
// released while a registration runs. README.md, "Python".
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "mac_registration/config/parameter_table.hpp"
#include "mac_registration/config/preset_file.hpp"
#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/cloud_registration.hpp"
#include "mac_registration/features/map_relocalization.hpp"

namespace py = pybind11;
using namespace mac_registration;
using namespace mac_registration::python;

namespace {

Eigen::Matrix4d matrixOf(const Eigen::Isometry3d& T) { return T.matrix(); }

// ---- the configuration

// A Python value as the table takes it: bool, int, float (numpy scalars too), or text parsed as a preset's.
void setFromPython(RegistrationConfig& config, const std::string& key, const py::handle& value) {
  if (py::isinstance<py::str>(value)) {
    setParameter(config, key, value.cast<std::string>());
  } else if (py::isinstance<py::bool_>(value) ||
             py::isinstance(value, py::module_::import("numpy").attr("bool_"))) {
    setParameter(config, key,
                 ParameterValue(py::bool_(py::reinterpret_borrow<py::object>(value)).cast<bool>()));
  } else if (py::hasattr(value, "__index__")) {
    setParameter(config, key, ParameterValue(value.attr("__index__")().cast<long long>()));
  } else if (py::hasattr(value, "__float__")) {
    setParameter(config, key, ParameterValue(value.attr("__float__")().cast<double>()));
  } else {
    if (!findParameter(key)) throw std::invalid_argument("unknown parameter '" + key + "'");
    throw py::type_error(key + ": expected a number, a bool or a string, got " +
                         std::string(py::str(py::type::handle_of(value).attr("__name__"))));
  }
}

py::object toPython(const ParameterValue& value) {
  if (const auto* b = std::get_if<bool>(&value)) return py::bool_(*b);
  if (const auto* i = std::get_if<long long>(&value)) return py::int_(*i);
  if (const auto* d = std::get_if<double>(&value)) return py::float_(*d);
  return py::str(std::get<std::string>(value));
}

// The table key of a keyword argument: the key itself where it has no section (num_threads), or the key
// with its section's dot written as an underscore (graph_t_cmp), as dynamic_reconfigure names them.
std::string keyOfKeyword(const std::string& name) {
  if (findParameter(name)) return name;
  for (const auto& p : parameterTable()) {
    std::string underscored = p.key;
    for (char& c : underscored)
      if (c == '.') c = '_';
    if (underscored == name) return p.key;
  }
  throw std::invalid_argument("unknown parameter '" + name + "'");
}

// Every problem validateConfig() finds, one sentence a line, as the tools and the node word them.
void throwIfInvalid(const RegistrationConfig& config) {
  const auto problems = validateConfig(config);
  if (problems.empty()) return;
  std::string message;
  for (const auto& p : problems) message += (message.empty() ? "" : "\n") + p;
  throw std::invalid_argument(message);
}

// A preset's faults (an unknown key, a value of the wrong type: "file:line: ...") are the caller's, as a
// --set's are: ValueError, not RuntimeError.
void loadPreset(RegistrationConfig& config, const std::string& path) {
  try {
    loadPresetFile(config, path);
  } catch (const std::runtime_error& e) {
    throw std::invalid_argument(e.what());
  }
}

RegistrationConfig makeConfig(const py::object& preset, const py::object& overrides,
                              const py::kwargs& kwargs) {
  RegistrationConfig config;
  if (!preset.is_none()) loadPreset(config, py::str(preset).cast<std::string>());
  if (!overrides.is_none()) {
    if (py::isinstance<py::dict>(overrides)) {
      for (const auto& item : overrides.cast<py::dict>())
        setFromPython(config, py::str(item.first).cast<std::string>(), item.second);
    } else if (py::isinstance<py::str>(overrides)) {
      applyAssignment(config, overrides.cast<std::string>());
    } else {
      for (const auto& assignment : overrides) {
        if (!py::isinstance<py::str>(assignment))
          throw py::type_error("overrides: expected a dict or 'KEY=VALUE' strings");
        applyAssignment(config, assignment.cast<std::string>());
      }
    }
  }
  for (const auto& item : kwargs) {
    const std::string name = py::str(item.first).cast<std::string>();
    setFromPython(config, keyOfKeyword(name), item.second);
  }
  throwIfInvalid(config);
  return config;
}

const RegistrationConfig& configOrDefault(const std::optional<RegistrationConfig>& config) {
  static const RegistrationConfig defaults;
  return config ? *config : defaults;
}

// ---- results

// One registration as Python sees it: the core's result and, for clouds, the front end's side.
struct Result {
  MacResult mac;
  bool from_clouds = false;
  FrontEndStats front_end;
  Eigen::Matrix3Xd source_matches, target_matches;  // the front end's correspondences (clouds only)
  StageTimes times;                                 // the whole registration's
};

Result fromCorrespondences(MacResult mac) {
  Result r;
  r.times = mac.times;
  r.mac = std::move(mac);
  return r;
}

Result fromClouds(const CloudRegistrationResult& cloud) {
  Result r;
  r.mac = cloud.registration;
  r.from_clouds = true;
  r.front_end = cloud.features.stats;
  r.source_matches = cloud.features.correspondences.source_points;
  r.target_matches = cloud.features.correspondences.target_points;
  r.times = cloud.times();
  return r;
}

// What mac_register refuses with exit status 2 (bad arguments, unusable input) is an exception here; every
// other outcome, success or not, is a result.
void throwIfRefused(const MacResult& mac) {
  if (mac.status == RegistrationStatus::kInvalidParameters || mac.status == RegistrationStatus::kInvalidInput)
    throw std::invalid_argument(mac.message);
}

struct StopToken {
  StopFlag flag{false};
};

const StopFlag* flagOf(const std::shared_ptr<StopToken>& stop) { return stop ? &stop->flag : nullptr; }

// A map described once, with the configuration it was described with (a query's default).
struct MapHandle {
  DescribedMap map;
  RegistrationConfig config;
  std::size_t points = 0;
};

struct Relocalization {
  RelocalizationResult result;
};

// A field of a plain struct, bound read-only; each class lists its fields in _fields (as_dict(), repr).
#define MAC_FIELD(cls, type, name) cls.def_readonly(#name, &type::name)

}  // namespace

PYBIND11_MODULE(_mac, m) {
  m.doc() =
      "MAC (maximal cliques) point cloud registration: the C++ core, its parameter table and the PCL front "
      "end (README.md, \"Python\").";

  py::register_exception<Cancelled>(m, "Cancelled", PyExc_RuntimeError);

  py::enum_<RegistrationStatus>(m, "Status", "RegistrationStatus; the values are RegistrationResult.status's")
      .value("SUCCESS", RegistrationStatus::kSuccess)
      .value("INVALID_PARAMETERS", RegistrationStatus::kInvalidParameters)
      .value("INVALID_INPUT", RegistrationStatus::kInvalidInput)
      .value("TOO_FEW_CORRESPONDENCES", RegistrationStatus::kTooFewCorrespondences)
      .value("EMPTY_GRAPH", RegistrationStatus::kEmptyGraph)
      .value("NO_CLIQUE", RegistrationStatus::kNoClique)
      .value("NO_VALID_HYPOTHESIS", RegistrationStatus::kNoValidHypothesis)
      .value("TOO_FEW_INLIERS", RegistrationStatus::kTooFewInliers)
      .value("INTERNAL_ERROR", RegistrationStatus::kInternalError)
      .value("CANCELLED", RegistrationStatus::kCancelled)
      .value("UNVERIFIED", RegistrationStatus::kUnverified)
      .def_property_readonly("text", [](RegistrationStatus s) { return std::string(toString(s)); });

  py::enum_<RelocalizationOutcome>(m, "Outcome", "RelocalizationOutcome")
      .value("LOCALIZED", RelocalizationOutcome::kLocalized)
      .value("NOT_LOCALIZED", RelocalizationOutcome::kNotLocalized)
      .value("AMBIGUOUS", RelocalizationOutcome::kAmbiguous)
      .value("INVALID_INPUT", RelocalizationOutcome::kInvalidInput)
      .value("CANCELLED", RelocalizationOutcome::kCancelled)
      .def_property_readonly("text", [](RelocalizationOutcome o) { return std::string(toString(o)); });

  // ---- configuration
  py::class_<RegistrationConfig>(
      m, "Config",
      "Every parameter of the registration: the built-in defaults (mac_register's without "
      "--config), a preset file, then overrides, each through the parameter table.")
      .def(py::init(&makeConfig), py::arg("preset") = py::none(), py::arg("overrides") = py::none())
      .def("__getitem__",
           [](const RegistrationConfig& c, const std::string& key) {
             const Parameter* p = findParameter(key);
             if (!p) throw py::key_error("unknown parameter '" + key + "'");
             return toPython(p->get(c));
           })
      .def("__setitem__",
           [](RegistrationConfig& c, const std::string& key, const py::handle& value) {
             RegistrationConfig next = c;
             setFromPython(next, key, value);
             throwIfInvalid(next);
             c = next;
           })
      .def("__contains__",
           [](const RegistrationConfig&, const std::string& key) { return findParameter(key) != nullptr; })
      .def("keys",
           [](const RegistrationConfig&) {
             std::vector<std::string> keys;
             for (const auto& p : parameterTable()) keys.push_back(p.key);
             return keys;
           })
      .def("as_dict",
           [](const RegistrationConfig& c) {
             py::dict out;
             for (const auto& p : parameterTable()) out[py::str(p.key)] = toPython(p.get(c));
             return out;
           })
      .def("copy", [](const RegistrationConfig& c) { return c; })
      .def(
          "describe", [](const RegistrationConfig& c) { return describeConfig(c); },
          "Every parameter as 'key = value [unit]', one a line, as the node's start-up log lists them.")
      .def("__repr__", [](const RegistrationConfig& c) {
        std::string changed;
        const RegistrationConfig defaults;
        for (const auto& p : parameterTable()) {
          const std::string value = formatParameterValue(p.get(c));
          if (value != formatParameterValue(p.get(defaults)))
            changed += (changed.empty() ? "" : ", ") + p.key + "=" + value;
        }
        return "Config(" + (changed.empty() ? std::string("defaults") : "defaults, " + changed) + ")";
      });

  m.def(
      "parameters",
      []() {
        py::list out;
        for (const auto& p : parameterTable()) {
          py::dict row;
          static const char* const kTypes[] = {"real", "integer", "count", "bool", "choice", "text"};
          row["key"] = p.key;
          row["type"] = kTypes[static_cast<int>(p.type)];
          row["unit"] = p.unit;
          const bool numeric = p.type == ParameterType::kReal || p.type == ParameterType::kInteger ||
                               p.type == ParameterType::kCount;
          row["range"] = numeric ? p.range.text() : std::string();
          row["choices"] = p.choices;
          row["default"] = toPython(p.get(RegistrationConfig{}));
          row["doc"] = p.doc;
          out.append(row);
        }
        return out;
      },
      "The parameter table: one dict per parameter (key, type, unit, range, choices, default, doc).");

  // ---- results
  py::class_<RegistrationCounters> counters(m, "Counters");
  MAC_FIELD(counters, RegistrationCounters, correspondences);
  MAC_FIELD(counters, RegistrationCounters, dropped_non_finite);
  MAC_FIELD(counters, RegistrationCounters, graph_nodes);
  MAC_FIELD(counters, RegistrationCounters, first_order_edges);
  MAC_FIELD(counters, RegistrationCounters, graph_edges);
  MAC_FIELD(counters, RegistrationCounters, pruned_weak_edges);
  MAC_FIELD(counters, RegistrationCounters, cliques);
  MAC_FIELD(counters, RegistrationCounters, degeneracy);
  MAC_FIELD(counters, RegistrationCounters, thinned_nodes);
  MAC_FIELD(counters, RegistrationCounters, pruning_rounds);
  MAC_FIELD(counters, RegistrationCounters, selected_cliques);
  MAC_FIELD(counters, RegistrationCounters, hypotheses);
  MAC_FIELD(counters, RegistrationCounters, degenerate_cliques);
  MAC_FIELD(counters, RegistrationCounters, tilted_hypotheses);
  MAC_FIELD(counters, RegistrationCounters, inliers);
  MAC_FIELD(counters, RegistrationCounters, refinement_iterations);
  counters.attr("_fields") = py::make_tuple(
      "correspondences", "dropped_non_finite", "graph_nodes", "first_order_edges", "graph_edges",
      "pruned_weak_edges", "cliques", "degeneracy", "thinned_nodes", "pruning_rounds", "selected_cliques",
      "hypotheses", "degenerate_cliques", "tilted_hypotheses", "inliers", "refinement_iterations");

  py::class_<StageTimes> times(m, "StageTimes", "Wall-clock milliseconds per stage, in the order they run.");
  MAC_FIELD(times, StageTimes, resolution_ms);
  MAC_FIELD(times, StageTimes, downsample_ms);
  MAC_FIELD(times, StageTimes, normals_ms);
  MAC_FIELD(times, StageTimes, features_ms);
  MAC_FIELD(times, StageTimes, matching_ms);
  MAC_FIELD(times, StageTimes, graph_ms);
  MAC_FIELD(times, StageTimes, second_order_ms);
  MAC_FIELD(times, StageTimes, clique_search_ms);
  MAC_FIELD(times, StageTimes, clique_wait_ms);
  MAC_FIELD(times, StageTimes, selection_ms);
  MAC_FIELD(times, StageTimes, hypotheses_ms);
  MAC_FIELD(times, StageTimes, evaluation_ms);
  MAC_FIELD(times, StageTimes, refinement_ms);
  MAC_FIELD(times, StageTimes, verification_ms);
  MAC_FIELD(times, StageTimes, fine_alignment_ms);
  MAC_FIELD(times, StageTimes, total_ms);
  times.def_property_readonly("front_end_ms", &StageTimes::frontEndMs);
  times.attr("_fields") =
      py::make_tuple("resolution_ms", "downsample_ms", "normals_ms", "features_ms", "matching_ms", "graph_ms",
                     "second_order_ms", "clique_search_ms", "clique_wait_ms", "selection_ms", "hypotheses_ms",
                     "evaluation_ms", "refinement_ms", "verification_ms", "fine_alignment_ms", "total_ms");

  py::class_<VerificationSignals> signals(
      m, "VerificationSignals", "The evidence the verification decided from; NaN where not measured.");
  MAC_FIELD(signals, VerificationSignals, rival_ratio);
  MAC_FIELD(signals, VerificationSignals, rival_rotation_deg);
  MAC_FIELD(signals, VerificationSignals, rival_displacement);
  MAC_FIELD(signals, VerificationSignals, chance_inliers);
  MAC_FIELD(signals, VerificationSignals, chance_significance);
  MAC_FIELD(signals, VerificationSignals, inlier_planarity);
  MAC_FIELD(signals, VerificationSignals, inlier_linearity);
  MAC_FIELD(signals, VerificationSignals, scene_planarity);
  MAC_FIELD(signals, VerificationSignals, fine_alignment_move);
  MAC_FIELD(signals, VerificationSignals, fine_alignment_converged);
  MAC_FIELD(signals, VerificationSignals, fine_alignment_support);
  MAC_FIELD(signals, VerificationSignals, aligned_overlap);
  MAC_FIELD(signals, VerificationSignals, seen_on_surface);
  MAC_FIELD(signals, VerificationSignals, surface_agreement);
  MAC_FIELD(signals, VerificationSignals, free_space_violation);
  signals.attr("_fields") =
      py::make_tuple("rival_ratio", "rival_rotation_deg", "rival_displacement", "chance_inliers",
                     "chance_significance", "inlier_planarity", "inlier_linearity", "scene_planarity",
                     "fine_alignment_move", "fine_alignment_converged", "fine_alignment_support",
                     "aligned_overlap", "seen_on_surface", "surface_agreement", "free_space_violation");

  py::class_<EvidenceTerm> evidence(m, "EvidenceTerm");
  MAC_FIELD(evidence, EvidenceTerm, signal);
  MAC_FIELD(evidence, EvidenceTerm, log_odds);
  MAC_FIELD(evidence, EvidenceTerm, reason);
  evidence.attr("_fields") = py::make_tuple("signal", "log_odds", "reason");

  py::class_<PoseAlternative> alternative(m, "Alternative",
                                          "A distinct pose competing with the reported one.");
  alternative.def_property_readonly("T_target_source",
                                    [](const PoseAlternative& a) { return matrixOf(a.T_target_source); });
  MAC_FIELD(alternative, PoseAlternative, score);
  MAC_FIELD(alternative, PoseAlternative, inliers);
  MAC_FIELD(alternative, PoseAlternative, score_ratio);
  MAC_FIELD(alternative, PoseAlternative, rotation_deg);
  MAC_FIELD(alternative, PoseAlternative, displacement);
  alternative.attr("_fields") =
      py::make_tuple("T_target_source", "score", "inliers", "score_ratio", "rotation_deg", "displacement");

  py::class_<FineAlignment> fine(m, "FineAlignment", "The point-to-plane fine alignment on the clouds.");
  MAC_FIELD(fine, FineAlignment, ran);
  MAC_FIELD(fine, FineAlignment, converged);
  MAC_FIELD(fine, FineAlignment, iterations);
  fine.def_property_readonly("start", [](const FineAlignment& f) { return matrixOf(f.start); });
  fine.def_property_readonly("T_target_source",
                             [](const FineAlignment& f) { return matrixOf(f.T_target_source); });
  MAC_FIELD(fine, FineAlignment, fitness);
  MAC_FIELD(fine, FineAlignment, rmse);
  MAC_FIELD(fine, FineAlignment, rotation_deg);
  MAC_FIELD(fine, FineAlignment, translation_m);
  MAC_FIELD(fine, FineAlignment, displacement);
  fine.def_property_readonly("covariance",
                             [](const FineAlignment& f) { return Eigen::MatrixXd(f.covariance); });
  fine.attr("_fields") =
      py::make_tuple("ran", "converged", "iterations", "start", "T_target_source", "fitness", "rmse",
                     "rotation_deg", "translation_m", "displacement", "covariance");

  py::class_<FrontEndStats> front_end(m, "FrontEndStats", "What the PCL front end did with the two clouds.");
  MAC_FIELD(front_end, FrontEndStats, source_points);
  MAC_FIELD(front_end, FrontEndStats, target_points);
  MAC_FIELD(front_end, FrontEndStats, source_dropped);
  MAC_FIELD(front_end, FrontEndStats, target_dropped);
  MAC_FIELD(front_end, FrontEndStats, source_keypoints);
  MAC_FIELD(front_end, FrontEndStats, target_keypoints);
  MAC_FIELD(front_end, FrontEndStats, source_no_feature);
  MAC_FIELD(front_end, FrontEndStats, target_no_feature);
  MAC_FIELD(front_end, FrontEndStats, rejected_mutual);
  MAC_FIELD(front_end, FrontEndStats, rejected_ratio);
  MAC_FIELD(front_end, FrontEndStats, truncated);
  MAC_FIELD(front_end, FrontEndStats, resolution);
  MAC_FIELD(front_end, FrontEndStats, voxel_size);
  MAC_FIELD(front_end, FrontEndStats, support_scale);
  front_end.def_readonly("times", &FrontEndStats::times);
  front_end.attr("_fields") =
      py::make_tuple("source_points", "target_points", "source_dropped", "target_dropped", "source_keypoints",
                     "target_keypoints", "source_no_feature", "target_no_feature", "rejected_mutual",
                     "rejected_ratio", "truncated", "resolution", "voxel_size", "support_scale");

  py::class_<Result> result(m, "Result",
                            "One registration's outcome (MacResult, and the front end's for clouds).");
  result.def_property_readonly("success", [](const Result& r) { return r.mac.success; })
      .def_property_readonly("status", [](const Result& r) { return r.mac.status; })
      .def_property_readonly("message", [](const Result& r) { return r.mac.message; })
      .def_property_readonly("warnings", [](const Result& r) { return r.mac.warnings; })
      .def_property_readonly("T_target_source",
                             [](const Result& r) { return matrixOf(r.mac.T_target_source); })
      .def_property_readonly("has_estimate", [](const Result& r) { return hasEstimate(r.mac); })
      .def_property_readonly(
          "inlier_indices",
          [](const Result& r) {
            py::array_t<std::int64_t> out(static_cast<py::ssize_t>(r.mac.inlier_indices.size()));
            auto view = out.mutable_unchecked<1>();
            for (std::size_t i = 0; i < r.mac.inlier_indices.size(); ++i)
              view(py::ssize_t(i)) = r.mac.inlier_indices[i];
            return out;
          })
      .def_property_readonly("score", [](const Result& r) { return r.mac.score; })
      .def_property_readonly("confidence", [](const Result& r) { return r.mac.confidence; })
      .def_property_readonly("clique_search_complete",
                             [](const Result& r) { return r.mac.clique_search_complete; })
      .def_property_readonly("graph_reduced", [](const Result& r) { return r.mac.graph_reduced; })
      .def_property_readonly("counters", [](const Result& r) { return r.mac.counters; })
      .def_property_readonly("times", [](const Result& r) { return r.times; })
      .def_property_readonly("verification", [](const Result& r) { return r.mac.verification; })
      .def_property_readonly("evidence", [](const Result& r) { return r.mac.evidence; })
      .def_property_readonly("fine_alignment", [](const Result& r) { return r.mac.fine_alignment; })
      .def_property_readonly("alternatives", [](const Result& r) { return r.mac.alternatives; })
      .def_property_readonly("front_end",
                             [](const Result& r) -> py::object {
                               if (!r.from_clouds) return py::none();
                               return py::cast(r.front_end);
                             })
      .def_property_readonly("correspondences", [](const Result& r) -> py::object {
        if (!r.from_clouds) return py::none();
        return py::make_tuple(rowsOf(r.source_matches), rowsOf(r.target_matches));
      });

  py::class_<StopToken, std::shared_ptr<StopToken>>(
      m, "StopFlag", "Raised from another thread, it ends a registration early with status CANCELLED.")
      .def(py::init<>())
      .def("set", [](StopToken& s) { s.flag.store(true); })
      .def("clear", [](StopToken& s) { s.flag.store(false); })
      .def("is_set", [](const StopToken& s) { return s.flag.load(); });

  // ---- registering
  m.def(
      "_register_correspondences",
      [](const py::handle& source, const py::handle& target, const std::optional<RegistrationConfig>& config,
         const std::shared_ptr<StopToken>& stop) {
        CorrespondenceSet set;
        set.source_points = toMatrix(source, "source");
        set.target_points = toMatrix(target, "target");
        if (set.source_points.cols() != set.target_points.cols()) {
          throw py::value_error("source and target must hold one row per correspondence: " +
                                std::to_string(set.source_points.cols()) + " and " +
                                std::to_string(set.target_points.cols()) + " rows");
        }
        const RegistrationConfig& c = configOrDefault(config);
        MacResult mac;
        {
          py::gil_scoped_release release;
          mac = registerCorrespondences(set, c.mac, flagOf(stop));
        }
        throwIfRefused(mac);
        return fromCorrespondences(std::move(mac));
      },
      py::arg("source"), py::arg("target"), py::arg("config") = py::none(), py::kw_only(),
      py::arg("stop") = py::none());

  m.def(
      "_register_clouds",
      [](const py::handle& source, const py::handle& target, const std::optional<RegistrationConfig>& config,
         const py::object& source_viewpoint, const py::object& target_viewpoint,
         const std::shared_ptr<StopToken>& stop) {
        const PointCloud::Ptr s = toCloud(source, "source", source_viewpoint, "source_viewpoint");
        const PointCloud::Ptr t = toCloud(target, "target", target_viewpoint, "target_viewpoint");
        const RegistrationConfig& c = configOrDefault(config);
        CloudRegistrationResult cloud;
        {
          py::gil_scoped_release release;
          cloud = registerClouds(*s, *t, c.features, c.mac, flagOf(stop));
        }
        throwIfRefused(cloud.registration);
        return fromClouds(cloud);
      },
      py::arg("source"), py::arg("target"), py::arg("config") = py::none(), py::kw_only(),
      py::arg("source_viewpoint") = py::none(), py::arg("target_viewpoint") = py::none(),
      py::arg("stop") = py::none());

  // ---- map relocalization
  py::class_<MapHandle, std::shared_ptr<MapHandle>>(
      m, "DescribedMap", "A map described once (describe_map), for any number of queries.")
      .def_property_readonly("points", [](const MapHandle& h) { return h.points; })
      .def_property_readonly("keypoints", [](const MapHandle& h) { return rowsOf(*h.map.cloud.keypoints); })
      .def_property_readonly("origin", [](const MapHandle& h) { return Eigen::Vector3d(h.map.origin); })
      .def_property_readonly("place_spacing", [](const MapHandle& h) { return h.map.cell_size; })
      .def_property_readonly("places", [](const MapHandle& h) { return h.map.columns * h.map.rows; })
      .def_property_readonly("describe_ms", [](const MapHandle& h) { return h.map.describe_ms; })
      .def_property_readonly("bytes", [](const MapHandle& h) { return h.map.bytes(); })
      .def_property_readonly("config", [](const MapHandle& h) { return h.config; });

  py::class_<PlaceCandidate>(m, "PlaceCandidate", "A place of the map as ranked for a query.")
      .def_property_readonly("centre", [](const PlaceCandidate& p) { return Eigen::Vector3d(p.centre); })
      .def_readonly("score", &PlaceCandidate::score)
      .def_readonly("votes", &PlaceCandidate::votes)
      .def_readonly("keypoints", &PlaceCandidate::keypoints)
      .def_readonly("registered", &PlaceCandidate::registered)
      .def_readonly("unconstrained", &PlaceCandidate::unconstrained)
      .def_property_readonly("T_map_query", [](const PlaceCandidate& p) { return matrixOf(p.T_map_query); })
      .def_property_readonly("registration", [](const PlaceCandidate& p) -> py::object {
        if (!p.registered) return py::none();
        return py::cast(fromClouds(p.registration));
      });

  py::class_<Relocalization>(m, "RelocalizationResult",
                             "Where a query lies in a map, or why that is not known.")
      .def_property_readonly("outcome", [](const Relocalization& r) { return r.result.outcome; })
      .def_property_readonly("success", [](const Relocalization& r) { return r.result.success; })
      .def_property_readonly("message", [](const Relocalization& r) { return r.result.message; })
      .def_property_readonly("T_map_query",
                             [](const Relocalization& r) { return matrixOf(r.result.T_map_query); })
      .def_property_readonly("confidence", [](const Relocalization& r) { return r.result.confidence; })
      .def_property_readonly("chosen", [](const Relocalization& r) { return r.result.chosen; })
      .def_property_readonly("candidates", [](const Relocalization& r) { return r.result.candidates; })
      .def_property_readonly("query_radius", [](const Relocalization& r) { return r.result.query_radius; })
      .def_property_readonly("query_keypoints",
                             [](const Relocalization& r) { return r.result.query_keypoints; })
      .def_property_readonly("describe_ms", [](const Relocalization& r) { return r.result.describe_ms; })
      .def_property_readonly("ranking_ms", [](const Relocalization& r) { return r.result.ranking_ms; })
      .def_property_readonly("registration_ms",
                             [](const Relocalization& r) { return r.result.registration_ms; })
      .def_property_readonly("total_ms", [](const Relocalization& r) { return r.result.total_ms; });

  m.def(
      "_describe_map",
      [](const py::handle& map_points, const std::optional<RegistrationConfig>& config,
         const py::object& map_origin, const std::shared_ptr<StopToken>& stop) {
        // Given an origin, the points are relative to it already (load_map's); else they are in the map
        // frame and leave it for a local one where they lie far from zero, as mac_relocalize reads a map.
        PointCloud::Ptr cloud;
        Eigen::Vector3d origin = Eigen::Vector3d::Zero();
        if (!map_origin.is_none()) {
          origin = vector3Of(map_origin, "map_origin");
          cloud = toCloud(map_points, "map_points", py::none(), "");
        } else {
          origin = localOriginOf(map_points, "map_points");
          cloud = toCloud(map_points, "map_points", py::none(), "", origin);
        }
        auto handle = std::make_shared<MapHandle>();
        handle->config = configOrDefault(config);
        handle->points = cloud->size();
        {
          py::gil_scoped_release release;
          handle->map = describeMap(*cloud, handle->config.features, handle->config.relocalization,
                                    flagOf(stop), origin);
        }
        return handle;
      },
      py::arg("map_points"), py::arg("config") = py::none(), py::kw_only(),
      py::arg("map_origin") = py::none(), py::arg("stop") = py::none());

  m.def(
      "_relocalize",
      [](const std::shared_ptr<MapHandle>& map, const py::handle& query_points,
         const std::optional<RegistrationConfig>& config, const py::object& search_centre,
         const std::optional<double>& search_radius, const py::object& viewpoint,
         const std::shared_ptr<StopToken>& stop) {
        if (!map) throw py::type_error("map: expected a DescribedMap (from describe_map)");
        const PointCloud::Ptr query = toCloud(query_points, "query_points", viewpoint, "viewpoint");
        std::optional<SearchArea> area;
        if (!search_centre.is_none() || search_radius) {
          if (search_centre.is_none() || !search_radius)
            throw py::value_error("a search area needs both search_centre (x, y) and search_radius [m]");
          const auto centre = py::array_t<double, py::array::forcecast>::ensure(search_centre);
          if (!centre || centre.size() != 2)
            throw py::value_error("search_centre: expected 2 coordinates (x, y) in the map frame [m]");
          area = SearchArea{Eigen::Vector2d(centre.data()[0], centre.data()[1]), *search_radius};
        }
        const RegistrationConfig& c = config ? *config : map->config;
        Relocalization out;
        {
          py::gil_scoped_release release;
          out.result = relocalize(map->map, *query, c.features, c.mac, c.relocalization, flagOf(stop),
                                  area ? &*area : nullptr);
        }
        if (out.result.outcome == RelocalizationOutcome::kInvalidInput)
          throw std::invalid_argument(out.result.message);
        return out;
      },
      py::arg("map"), py::arg("query_points"), py::arg("config") = py::none(), py::kw_only(),
      py::arg("search_centre") = py::none(), py::arg("search_radius") = py::none(),
      py::arg("viewpoint") = py::none(), py::arg("stop") = py::none());

  // ---- files and the machine
  m.def(
      "_load_cloud",
      [](const std::string& path, bool local) {
        std::vector<std::string> warnings;
        LocalCloud cloud;
        try {
          py::gil_scoped_release release;
          if (local)
            cloud = loadLocalCloud(path, &warnings);
          else
            cloud.cloud = loadCloud(path, &warnings);
        } catch (const std::runtime_error& e) {
          // A missing, unreadable or malformed file: the message names it and the reason.
          PyErr_SetString(PyExc_OSError, e.what());
          throw py::error_already_set();
        }
        const Eigen::Vector4f& o = cloud.cloud->sensor_origin_;
        return py::make_tuple(rowsOf(*cloud.cloud), Eigen::Vector3d(o.x(), o.y(), o.z()), warnings,
                              Eigen::Vector3d(cloud.origin));
      },
      py::arg("path"), py::arg("local") = false);

  m.def("kernels_in_use", &kernelsInUse, "The SIMD kernels this process runs (as mac_register prints them).");
}
