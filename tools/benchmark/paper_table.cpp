#include "paper_table.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "mac_registration/core/mac_result.hpp"

namespace mac_registration {
namespace {

const MethodOutcome* find(const PairOutcome& pair, const std::string& method) {
  for (const MethodOutcome& m : pair.methods) {
    if (m.method == method) return &m;
  }
  return nullptr;
}

template <typename Key>
std::vector<std::string> inOrder(const std::vector<PairOutcome>& outcomes, Key key) {
  std::vector<std::string> seen;
  for (const PairOutcome& p : outcomes) {
    if (std::find(seen.begin(), seen.end(), key(p)) == seen.end()) seen.push_back(key(p));
  }
  return seen;
}

bool isGross(const MethodOutcome& m, const GrossError& gross) {
  return gross.classifies(m.rotation_error_deg, m.translation_error);
}

PaperRow summarizeGroup(const std::string& benchmark, const std::string& scene,
                        const std::vector<const PairOutcome*>& pairs, const std::string& method,
                        const GrossError& gross) {
  PaperRow row;
  row.benchmark = benchmark;
  row.scene = scene;
  row.pairs = pairs.size();
  std::vector<std::string> scenes;
  std::vector<double> totals, method_times;
  double rotation = 0.0, translation = 0.0;
  for (const PairOutcome* pair : pairs) {
    if (std::find(scenes.begin(), scenes.end(), pair->scene) == scenes.end()) scenes.push_back(pair->scene);
    const MethodOutcome* m = find(*pair, method);
    if (!m) continue;
    totals.push_back(pair->frontEndOf(*m).frontEndMs() + m->times.total_ms);
    method_times.push_back(m->times.total_ms);
    row.right_estimates += acceptedAt(*m, 0.0) && m->within_criterion;
    if (!m->registered) continue;
    ++row.successes;
    if (m->recalled) {
      ++row.right;
      rotation += m->rotation_error_deg;
      translation += m->translation_error;
    } else {
      ++row.wrong;
      row.gross += isGross(*m, gross);
    }
  }
  row.scenes = scenes.size();
  if (row.right > 0) {
    row.mean_rotation_error_deg = rotation / double(row.right);
    row.mean_translation_error = translation / double(row.right);
  }
  if (!totals.empty()) {
    double sum = 0.0;
    for (double t : totals) sum += t;
    row.mean_ms = sum / double(totals.size());
    row.median_ms = median(totals);
    row.median_method_ms = median(method_times);
  }
  return row;
}

std::vector<const PairOutcome*> select(const std::vector<PairOutcome>& outcomes, const std::string& benchmark,
                                       const std::string* scene) {
  std::vector<const PairOutcome*> chosen;
  for (const PairOutcome& p : outcomes) {
    if (p.subset == benchmark && (!scene || p.scene == *scene)) chosen.push_back(&p);
  }
  return chosen;
}

std::string percent(double share) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(2) << 100.0 * share << " %";
  return text.str();
}

std::string number(double value, int digits) {
  if (std::isnan(value)) return "-";
  std::ostringstream text;
  text << std::fixed << std::setprecision(digits) << value;
  return text.str();
}

}  // namespace

bool acceptedAt(const MethodOutcome& m, double min_confidence) {
  // A success or an unverified result carries the pose the verification judged, and its confidence: the
  // same comparison decideVerification made with the run's own threshold.
  const bool judged = m.registered || m.status == toString(RegistrationStatus::kUnverified);
  return judged && !std::isnan(m.confidence) && m.confidence >= min_confidence;
}

std::vector<PaperRow> paperRows(const std::vector<PairOutcome>& outcomes, const std::string& method,
                                const GrossError& gross, bool per_scene) {
  std::vector<PaperRow> rows;
  for (const std::string& benchmark : inOrder(outcomes, [](const PairOutcome& p) { return p.subset; })) {
    rows.push_back(summarizeGroup(benchmark, "", select(outcomes, benchmark, nullptr), method, gross));
    if (!per_scene) continue;
    std::vector<PairOutcome> in_benchmark;
    for (const PairOutcome* p : select(outcomes, benchmark, nullptr)) in_benchmark.push_back(*p);
    for (const std::string& scene : inOrder(in_benchmark, [](const PairOutcome& p) { return p.scene; }))
      rows.push_back(summarizeGroup(benchmark, scene, select(outcomes, benchmark, &scene), method, gross));
  }
  return rows;
}

std::vector<ThresholdRow> thresholdRows(const std::vector<PairOutcome>& outcomes, const std::string& method,
                                        const std::vector<double>& thresholds, const GrossError& gross) {
  std::vector<ThresholdRow> rows;
  for (const std::string& benchmark : inOrder(outcomes, [](const PairOutcome& p) { return p.subset; })) {
    const std::vector<const PairOutcome*> pairs = select(outcomes, benchmark, nullptr);
    for (double threshold : thresholds) {
      ThresholdRow row;
      row.benchmark = benchmark;
      row.min_confidence = threshold;
      row.pairs = pairs.size();
      for (const PairOutcome* pair : pairs) {
        const MethodOutcome* m = find(*pair, method);
        if (!m || !acceptedAt(*m, threshold)) continue;
        ++row.accepted;
        if (m->within_criterion) {
          ++row.right;
        } else {
          ++row.wrong;
          row.gross += isGross(*m, gross);
        }
      }
      rows.push_back(row);
    }
  }
  return rows;
}

void printPaperTable(std::ostream& out, const std::vector<PaperRow>& rows,
                     const std::vector<ThresholdRow>& thresholds, double current,
                     const SuccessCriterion& criterion, const GrossError& gross) {
  out << "Registration recall (RR): a reported success with RE <= " << criterion.max_rotation_deg
      << " deg and TE <= " << 100.0 * criterion.max_translation
      << " cm, of all pairs; RE/TE: means over the recalled pairs; time: front end + registration per pair "
         "(registration: the method alone); without verification: the pose within the criterion whenever the "
         "verification judged one; wrong: reported successes outside the criterion (gross: RE > "
      << gross.min_rotation_deg << " deg or TE > " << 100.0 * gross.min_translation
      << " cm); false accepts: wrong / successes.\n\n";
  out << "| benchmark | scene | pairs | RR | RE [deg] | TE [cm] | time mean / median [ms] | registration "
         "median [ms] | "
         "RR without verification | successes | wrong (gross) | false accepts |\n"
      << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const PaperRow& r : rows) {
    out << "| " << r.benchmark << " | "
        << (r.scene.empty() ? "all " + std::to_string(r.scenes) + (r.scenes == 1 ? " scene" : " scenes")
                            : r.scene)
        << " | " << r.pairs << " | " << percent(r.recall()) << " (" << r.right << ") | "
        << number(r.mean_rotation_error_deg, 2) << " | " << number(100.0 * r.mean_translation_error, 2)
        << " | " << number(r.mean_ms, 0) << " / " << number(r.median_ms, 0) << " | "
        << number(r.median_method_ms, 1) << " | " << percent(r.recallWithoutVerification()) << " ("
        << r.right_estimates << ") | " << r.successes << " | " << r.wrong << " (" << r.gross << ") | "
        << percent(r.falseAcceptRate()) << " |\n";
  }
  if (thresholds.empty()) return;
  out << "\nAt other verification.min_confidence, from the same results (a success or an unverified pose "
         "is accepted when its confidence reaches the threshold; the run's own: "
      << current << "):\n\n"
      << "| benchmark | min_confidence | successes | right | RR | wrong (gross) | false accepts |\n"
      << "|---|---|---|---|---|---|---|\n";
  for (const ThresholdRow& t : thresholds) {
    const bool own = std::abs(t.min_confidence - current) < 1e-9;
    const std::string mark = own ? "**" : "";
    out << "| " << t.benchmark << " | " << mark << t.min_confidence << mark << " | " << t.accepted << " | "
        << t.right << " | " << percent(t.recall()) << " | " << t.wrong << " (" << t.gross << ") | "
        << percent(t.falseAcceptRate()) << " |\n";
  }
}

}  // namespace mac_registration
