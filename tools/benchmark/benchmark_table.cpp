#include "benchmark_table.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <sstream>

namespace mac_registration {
double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t m = values.size() / 2;
  return values.size() % 2 ? values[m] : 0.5 * (values[m - 1] + values[m]);
}

namespace {

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
  std::vector<const StageTimes*> front_ends;
  std::vector<double> totals, peaks;
  double inlier_ratios = 0.0, rotation = 0.0, translation = 0.0;
  for (const PairOutcome* pair : pairs) {
    const auto it = std::find_if(pair->methods.begin(), pair->methods.end(),
                                 [&](const MethodOutcome& m) { return m.method == method; });
    if (it == pair->methods.end()) continue;
    ran.push_back(&*it);
    front_ends.push_back(&pair->frontEndOf(*it));
    totals.push_back(pair->frontEndOf(*it).frontEndMs() + it->times.total_ms);
    if (!std::isnan(it->peak_mb)) peaks.push_back(it->peak_mb);
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

  using F = StageTimes;
  StageTimes& f = row.median_front_end;
  f.resolution_ms = medianOf<F>(front_ends, [](const F& t) { return t.resolution_ms; });
  f.downsample_ms = medianOf<F>(front_ends, [](const F& t) { return t.downsample_ms; });
  f.normals_ms = medianOf<F>(front_ends, [](const F& t) { return t.normals_ms; });
  f.features_ms = medianOf<F>(front_ends, [](const F& t) { return t.features_ms; });
  f.matching_ms = medianOf<F>(front_ends, [](const F& t) { return t.matching_ms; });
  row.median_front_end_total_ms = medianOf<F>(front_ends, [](const F& t) { return t.frontEndMs(); });

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
  row.median_total_ms = median(totals);
  if (!peaks.empty()) row.median_peak_mb = median(peaks);
  return row;
}

template <typename T>
void appendUnique(std::vector<T>& list, const T& value) {
  if (std::find(list.begin(), list.end(), value) == list.end()) list.push_back(value);
}

const MethodOutcome* find(const PairOutcome& pair, const std::string& method) {
  for (const MethodOutcome& m : pair.methods) {
    if (m.method == method) return &m;
  }
  return nullptr;
}

// "ok RE/TE" or "MISS RE/TE" of one method on one pair, for the side-by-side table.
std::string verdict(const MethodOutcome& m) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(1) << (m.recalled ? "ok " : "MISS ");
  if (std::isnan(m.rotation_error_deg))
    text << "-";
  else
    text << m.rotation_error_deg << "/" << 100.0 * m.translation_error;
  return text.str();
}

double ratio(double ours, double peer) { return peer > 0.0 ? ours / peer : std::nan(""); }

}  // namespace

std::vector<StageShare> stageShares(const StageTimes& f, const StageTimes& s, double total_ms) {
  std::vector<StageShare> shares = {
      {"resol", f.resolution_ms},   {"voxel", f.downsample_ms},      {"normals", f.normals_ms},
      {"fpfh", f.features_ms},      {"match", f.matching_ms},        {"graph", s.graph_ms},
      {"SOG", s.second_order_ms},   {"cliques", s.clique_search_ms}, {"select", s.selection_ms},
      {"hyp", s.hypotheses_ms},     {"eval", s.evaluation_ms},       {"refine", s.refinement_ms},
      {"verify", s.verification_ms}};
  double timed = 0.0;
  for (const StageShare& stage : shares) timed += stage.ms;
  shares.push_back({"other", std::max(0.0, total_ms - timed)});
  for (StageShare& stage : shares) stage.percent = total_ms > 0.0 ? 100.0 * stage.ms / total_ms : 0.0;
  return shares;
}

MethodOutcome judge(MethodOutcome outcome, const SuccessCriterion& criterion) {
  // NaN errors (no transform) compare false, so they are never accepted.
  outcome.within_criterion = criterion.accepts(outcome.rotation_error_deg, outcome.translation_error);
  outcome.recalled = outcome.registered && outcome.within_criterion;
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
    const StageTimes& f = r.median_front_end;
    const StageTimes& s = r.median_times;
    out << std::left << std::setw(subset_width) << r.subset << std::setw(method_width) << r.method
        << std::right << std::setprecision(1);
    for (double v : {f.resolution_ms, f.downsample_ms, f.normals_ms, f.features_ms, f.matching_ms, s.graph_ms,
                     s.second_order_ms, s.clique_search_ms, s.selection_ms, s.hypotheses_ms, s.evaluation_ms,
                     s.refinement_ms, s.verification_ms})
      out << std::setw(8) << v;
    out << std::setw(9) << s.total_ms << "\n";
  }
  out << "\nshare of the median total (front end + method) per stage [%]; other: the untimed rest and the "
         "baselines' method time\n"
      << std::left << std::setw(subset_width) << "subset" << std::setw(method_width) << "method"
      << std::right;
  for (const StageShare& stage : stageShares({}, {}, 0.0)) out << std::setw(8) << stage.name;
  out << std::setw(9) << "total" << std::setw(9) << "peakMB"
      << "\n";
  for (const SummaryRow& r : rows) {
    out << std::left << std::setw(subset_width) << r.subset << std::setw(method_width) << r.method
        << std::right << std::setprecision(1);
    for (const StageShare& stage : stageShares(r.median_front_end, r.median_times, r.median_total_ms))
      out << std::setw(8) << stage.percent;
    out << std::setw(9) << r.median_total_ms << std::setw(9) << r.median_peak_mb << "\n";
  }
  out.flags(old_flags);
  out.precision(old_precision);
}

void printPeerComparison(std::ostream& out, const std::vector<PairOutcome>& outcomes, const std::string& ours,
                         const std::string& peer) {
  std::vector<const PairOutcome*> both;
  for (const PairOutcome& p : outcomes) {
    if (find(p, ours) && find(p, peer)) both.push_back(&p);
  }
  if (both.empty()) return;
  const auto old_flags = out.flags();
  const auto old_precision = out.precision();
  std::size_t name_width = 10;
  for (const PairOutcome* p : both) name_width = std::max(name_width, p->name.size() + 2);
  out << "\n"
      << ours << " beside " << peer << " pair by pair: verdict RE[deg]/TE[cm]; ms per stage (voxel, "
      << "normals, fpfh, match+registration: ours match + method, " << peer << " its registration); peak MB; "
      << "ratio = " << ours << "/" << peer << "\n"
      << std::left << std::setw(int(name_width)) << "pair" << std::right;
  for (const std::string& m : {ours, peer})
    out << std::setw(18) << m << std::setw(7) << "voxel" << std::setw(8) << "normals" << std::setw(7)
        << "fpfh" << std::setw(8) << "reg" << std::setw(8) << "total" << std::setw(8) << "peakMB";
  out << std::setw(8) << "time x" << std::setw(8) << "mem x"
      << "\n";
  std::vector<double> time_ratios, memory_ratios;
  out << std::fixed << std::setprecision(0);
  for (const PairOutcome* p : both) {
    out << std::left << std::setw(int(name_width)) << p->name << std::right;
    double totals[2], peaks[2];
    int k = 0;
    for (const std::string& name : {ours, peer}) {
      const MethodOutcome& m = *find(*p, name);
      const StageTimes& f = p->frontEndOf(m);
      // ours: the resolution estimate (0 unless asked for) belongs to the front end's first stage
      totals[k] = f.frontEndMs() + m.times.total_ms;
      peaks[k] = m.peak_mb;
      out << std::setw(18) << verdict(m) << std::setw(7) << f.resolution_ms + f.downsample_ms << std::setw(8)
          << f.normals_ms << std::setw(7) << f.features_ms << std::setw(8) << f.matching_ms + m.times.total_ms
          << std::setw(8) << totals[k] << std::setw(8) << peaks[k];
      ++k;
    }
    time_ratios.push_back(ratio(totals[0], totals[1]));
    memory_ratios.push_back(ratio(peaks[0], peaks[1]));
    out << std::setprecision(2) << std::setw(8) << time_ratios.back() << std::setw(8) << memory_ratios.back()
        << std::setprecision(0) << "\n";
  }
  const auto finite = [](std::vector<double> v) {
    v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
    return v;
  };
  out << std::setprecision(2) << "median ratio " << ours << "/" << peer << " over " << both.size()
      << " pairs: time " << median(finite(time_ratios)) << ", peak memory " << median(finite(memory_ratios))
      << "\n";
  out.flags(old_flags);
  out.precision(old_precision);
}

void writeOutcomesCsv(std::ostream& out, const std::vector<PairOutcome>& outcomes) {
  out << "pair,scene,subset,method,correspondences,inlier_ratio,registered,status,confidence,rotation_error_"
         "deg,"
         "translation_error_m,within_criterion,recalled,inliers,resolution_ms,downsample_ms,normals_ms,fpfh_"
         "ms,matching_ms,"
         "graph_ms,second_order_ms,clique_search_ms,selection_ms,hypotheses_ms,evaluation_ms,refinement_ms,"
         "verification_ms,method_total_ms,source_points,target_points,total_ms,peak_mb";
  for (const StageShare& stage : stageShares({}, {}, 0.0)) out << "," << stage.name << "_share_pct";
  out << ",error\n";
  const auto quoted = [](const std::string& text) {
    std::string q = "\"";
    for (char c : text) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
  };
  out << std::setprecision(9);
  for (const PairOutcome& p : outcomes) {
    const StageTimes& f = p.front_end;
    const auto prefix = [&](const std::string& method) {
      out << quoted(p.name) << "," << quoted(p.scene) << "," << quoted(p.subset) << "," << method << ","
          << p.correspondences << "," << p.inlier_ratio << ",";
    };
    if (p.methods.empty()) {
      prefix("");
      out << "0,,,,,0,0,0," << f.resolution_ms << "," << f.downsample_ms << "," << f.normals_ms << ","
          << f.features_ms << "," << f.matching_ms << ",0,0,0,0,0,0,0,0,0," << p.source_points << ","
          << p.target_points << "," << f.frontEndMs() << ",nan";
      for (const StageShare& stage : stageShares(f, {}, f.frontEndMs())) out << "," << stage.percent;
      out << "," << quoted(p.error) << "\n";
      continue;
    }
    for (const MethodOutcome& m : p.methods) {
      const StageTimes& s = m.times;
      const StageTimes& f = p.frontEndOf(m);
      const double total = f.frontEndMs() + s.total_ms;
      prefix(m.method);
      out << m.registered << "," << quoted(m.status) << "," << m.confidence << "," << m.rotation_error_deg
          << "," << m.translation_error << "," << m.within_criterion << "," << m.recalled << "," << m.inliers
          << "," << f.resolution_ms << "," << f.downsample_ms << "," << f.normals_ms << "," << f.features_ms
          << "," << f.matching_ms << "," << s.graph_ms << "," << s.second_order_ms << ","
          << s.clique_search_ms << "," << s.selection_ms << "," << s.hypotheses_ms << "," << s.evaluation_ms
          << "," << s.refinement_ms << "," << s.verification_ms << "," << s.total_ms << "," << p.source_points
          << "," << p.target_points << "," << total << "," << m.peak_mb;
      for (const StageShare& stage : stageShares(f, s, total)) out << "," << stage.percent;
      out << "," << quoted(p.error) << "\n";
    }
  }
}

namespace {

std::string describeMethod(const MethodOutcome& m) {
  std::ostringstream text;
  text << m.method << " " << (m.recalled ? "ok  " : "MISS");
  if (!std::isnan(m.rotation_error_deg))
    text << std::fixed << std::setprecision(1) << " RE " << m.rotation_error_deg << " TE "
         << m.translation_error * 100.0 << "cm";
  if (!m.registered) text << " (" << m.status << ")";
  text << std::fixed << std::setprecision(0) << " " << m.times.total_ms << "ms";
  return text.str();
}

}  // namespace

void printPairProgress(std::ostream& out, std::size_t k, std::size_t count, const PairOutcome& r) {
  out << "[" << std::setw(3) << k + 1 << "/" << count << "] " << r.name << " (" << r.subset << ")";
  if (!r.error.empty()) {
    out << " ERROR: " << r.error << std::endl;
    return;
  }
  out << " " << r.correspondences << " corr, " << std::fixed << std::setprecision(1) << 100.0 * r.inlier_ratio
      << "% inliers, front end " << std::setprecision(0) << r.front_end.frontEndMs() << "ms";
  for (const MethodOutcome& m : r.methods) out << " | " << describeMethod(m);
  out << std::endl;
}

}  // namespace mac_registration
