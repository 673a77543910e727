#include "benchmark_table.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>

namespace mac_registration {
namespace {

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t m = values.size() / 2;
  return values.size() % 2 ? values[m] : 0.5 * (values[m - 1] + values[m]);
}

// The median of each field, taken separately: a "median pair" would not exist.
template <typename Record>
double medianOf(const std::vector<const Record*>& records,
                const std::function<double(const Record&)>& field) {
  std::vector<double> values;
  for (const Record* r : records) values.push_back(field(*r));
  return median(values);
}

SummaryRow summarizeGroup(const std::string& subset, const std::string& method,
                          const std::vector<const PairOutcome*>& pairs) {
  SummaryRow row;
  row.subset = subset;
  row.method = method;
  row.pairs = pairs.size();
  std::vector<const MethodOutcome*> ran;
  std::vector<const FrontEndTimes*> front_ends;
  double inlier_ratios = 0.0, rotation = 0.0, translation = 0.0;
  for (const PairOutcome* pair : pairs) {
    const auto it = std::find_if(pair->methods.begin(), pair->methods.end(),
                                 [&](const MethodOutcome& m) { return m.method == method; });
    if (it == pair->methods.end()) continue;
    ran.push_back(&*it);
    front_ends.push_back(&pair->front_end);
    inlier_ratios += pair->inlier_ratio;
    if (it->recalled) {
      ++row.recalled;
      rotation += it->rotation_error_deg;
      translation += it->translation_error;
    }
  }
  row.recall = row.pairs > 0 ? double(row.recalled) / double(row.pairs) : 0.0;
  if (row.recalled > 0) {
    row.mean_rotation_error_deg = rotation / double(row.recalled);
    row.mean_translation_error = translation / double(row.recalled);
  }
  row.mean_inlier_ratio = ran.empty() ? 0.0 : inlier_ratios / double(ran.size());

  using F = FrontEndTimes;
  FrontEndTimes& f = row.median_front_end;
  f.resolution_ms = medianOf<F>(front_ends, [](const F& t) { return t.resolution_ms; });
  f.downsample_ms = medianOf<F>(front_ends, [](const F& t) { return t.downsample_ms; });
  f.normals_ms = medianOf<F>(front_ends, [](const F& t) { return t.normals_ms; });
  f.features_ms = medianOf<F>(front_ends, [](const F& t) { return t.features_ms; });
  f.matching_ms = medianOf<F>(front_ends, [](const F& t) { return t.matching_ms; });
  row.median_front_end_total_ms = medianOf<F>(front_ends, [](const F& t) { return t.total(); });

  using M = MethodOutcome;
  StageTimes& s = row.median_times;
  s.graph_ms = medianOf<M>(ran, [](const M& m) { return m.times.graph_ms; });
  s.second_order_ms = medianOf<M>(ran, [](const M& m) { return m.times.second_order_ms; });
  s.clique_search_ms = medianOf<M>(ran, [](const M& m) { return m.times.clique_search_ms; });
  s.selection_ms = medianOf<M>(ran, [](const M& m) { return m.times.selection_ms; });
  s.hypotheses_ms = medianOf<M>(ran, [](const M& m) { return m.times.hypotheses_ms; });
  s.evaluation_ms = medianOf<M>(ran, [](const M& m) { return m.times.evaluation_ms; });
  s.refinement_ms = medianOf<M>(ran, [](const M& m) { return m.times.refinement_ms; });
  s.verification_ms = medianOf<M>(ran, [](const M& m) { return m.times.verification_ms; });
  s.total_ms = medianOf<M>(ran, [](const M& m) { return m.times.total_ms; });
  return row;
}

template <typename T>
void appendUnique(std::vector<T>& list, const T& value) {
  if (std::find(list.begin(), list.end(), value) == list.end()) list.push_back(value);
}

}  // namespace

MethodOutcome judge(MethodOutcome outcome, const SuccessCriterion& criterion) {
  // NaN errors (no transform) compare false, so they are never accepted.
  outcome.recalled =
      outcome.registered && criterion.accepts(outcome.rotation_error_deg, outcome.translation_error);
  return outcome;
}

std::vector<SummaryRow> summarize(const std::vector<PairOutcome>& outcomes) {
  std::vector<std::string> subsets, methods;
  for (const PairOutcome& pair : outcomes) {
    appendUnique(subsets, pair.subset);
    for (const MethodOutcome& m : pair.methods) appendUnique(methods, m.method);
  }
  std::vector<SummaryRow> rows;
  const auto addRows = [&](const std::string& subset, const std::vector<const PairOutcome*>& pairs) {
    for (const std::string& method : methods) rows.push_back(summarizeGroup(subset, method, pairs));
  };
  std::vector<const PairOutcome*> all;
  for (const PairOutcome& pair : outcomes) all.push_back(&pair);
  for (const std::string& subset : subsets) {
    std::vector<const PairOutcome*> in_subset;
    for (const PairOutcome* pair : all) {
      if (pair->subset == subset) in_subset.push_back(pair);
    }
    addRows(subset, in_subset);
  }
  if (subsets.size() > 1) addRows("all", all);
  return rows;
}

void printSummary(std::ostream& out, const std::vector<SummaryRow>& rows, const SuccessCriterion& criterion) {
  const auto old_flags = out.flags();
  const auto old_precision = out.precision();
  int subset_width = 12, method_width = 8;  // names as long as a scene's must not shift the columns
  for (const SummaryRow& r : rows) {
    subset_width = std::max(subset_width, int(r.subset.size()) + 2);
    method_width = std::max(method_width, int(r.method.size()) + 2);
  }
  out << "registration recall: RE <= " << criterion.max_rotation_deg
      << " deg and TE <= " << criterion.max_translation * 100.0
      << " cm; RE/TE averaged over the recalled pairs; times are medians\n";
  out << std::left << std::setw(subset_width) << "subset" << std::setw(method_width) << "method" << std::right
      << std::setw(6) << "pairs" << std::setw(10) << "recall" << std::setw(9) << "RE[deg]" << std::setw(8)
      << "TE[cm]" << std::setw(9) << "inlier%" << std::setw(13) << "front[ms]" << std::setw(12)
      << "method[ms]"
      << "\n";
  out << std::fixed;
  for (const SummaryRow& r : rows) {
    out << std::left << std::setw(subset_width) << r.subset << std::setw(method_width) << r.method
        << std::right << std::setw(6) << r.pairs << std::setw(9) << std::setprecision(2) << 100.0 * r.recall
        << "%" << std::setw(9) << r.mean_rotation_error_deg << std::setw(8)
        << 100.0 * r.mean_translation_error << std::setw(9) << 100.0 * r.mean_inlier_ratio << std::setw(13)
        << std::setprecision(1) << r.median_front_end_total_ms << std::setw(12) << r.median_times.total_ms
        << "\n";
  }
  out << "\nmedian time per stage [ms]\n"
      << std::left << std::setw(subset_width) << "subset" << std::setw(method_width) << "method" << std::right
      << std::setw(8) << "resol" << std::setw(8) << "voxel" << std::setw(8) << "normals" << std::setw(8)
      << "fpfh" << std::setw(8) << "match" << std::setw(8) << "graph" << std::setw(8) << "SOG" << std::setw(8)
      << "cliques" << std::setw(8) << "select" << std::setw(8) << "hyp" << std::setw(8) << "eval"
      << std::setw(8) << "refine" << std::setw(8) << "verify" << std::setw(9) << "total"
      << "\n";
  for (const SummaryRow& r : rows) {
    const FrontEndTimes& f = r.median_front_end;
    const StageTimes& s = r.median_times;
    out << std::left << std::setw(subset_width) << r.subset << std::setw(method_width) << r.method
        << std::right << std::setprecision(1);
    for (double v : {f.resolution_ms, f.downsample_ms, f.normals_ms, f.features_ms, f.matching_ms, s.graph_ms,
                     s.second_order_ms, s.clique_search_ms, s.selection_ms, s.hypotheses_ms, s.evaluation_ms,
                     s.refinement_ms, s.verification_ms})
      out << std::setw(8) << v;
    out << std::setw(9) << s.total_ms << "\n";
  }
  out.flags(old_flags);
  out.precision(old_precision);
}

void writeOutcomesCsv(std::ostream& out, const std::vector<PairOutcome>& outcomes) {
  out << "pair,subset,method,correspondences,inlier_ratio,registered,status,rotation_error_deg,"
         "translation_error_m,recalled,inliers,resolution_ms,downsample_ms,normals_ms,fpfh_ms,matching_ms,"
         "graph_ms,second_order_ms,clique_search_ms,selection_ms,hypotheses_ms,evaluation_ms,refinement_ms,"
         "verification_ms,method_total_ms,error\n";
  const auto quoted = [](const std::string& text) {
    std::string q = "\"";
    for (char c : text) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
  };
  out << std::setprecision(9);
  for (const PairOutcome& p : outcomes) {
    const FrontEndTimes& f = p.front_end;
    const auto prefix = [&](const std::string& method) {
      out << quoted(p.name) << "," << quoted(p.subset) << "," << method << "," << p.correspondences << ","
          << p.inlier_ratio << ",";
    };
    if (p.methods.empty()) {
      prefix("");
      out << "0,,,,0,0," << f.resolution_ms << "," << f.downsample_ms << "," << f.normals_ms << ","
          << f.features_ms << "," << f.matching_ms << ",0,0,0,0,0,0,0,0,0," << quoted(p.error) << "\n";
      continue;
    }
    for (const MethodOutcome& m : p.methods) {
      const StageTimes& s = m.times;
      prefix(m.method);
      out << m.registered << "," << quoted(m.status) << "," << m.rotation_error_deg << ","
          << m.translation_error << "," << m.recalled << "," << m.inliers << "," << f.resolution_ms << ","
          << f.downsample_ms << "," << f.normals_ms << "," << f.features_ms << "," << f.matching_ms << ","
          << s.graph_ms << "," << s.second_order_ms << "," << s.clique_search_ms << "," << s.selection_ms
          << "," << s.hypotheses_ms << "," << s.evaluation_ms << "," << s.refinement_ms << ","
          << s.verification_ms << "," << s.total_ms << "," << quoted(p.error) << "\n";
    }
  }
}

}  // namespace mac_registration
