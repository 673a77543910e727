#include "core_cases.hpp"

#include <algorithm>
#include <iomanip>

namespace mac_registration {

StageTimes stageTimesOf(const CaseResult& r) {
  StageTimes t;
  t.graph_ms = r.graph;
  t.second_order_ms = r.second_order;
  t.clique_search_ms = r.cliques;
  t.selection_ms = r.selection;
  t.hypotheses_ms = r.hypotheses;
  t.evaluation_ms = r.evaluation;
  t.refinement_ms = r.refinement;
  t.verification_ms = r.verification;
  t.total_ms = r.total;
  return t;
}

// stageShares from the first core stage on: the front end's entries are zero here.
std::vector<StageShare> coreShares(const CaseResult& r) {
  std::vector<StageShare> shares = stageShares({}, stageTimesOf(r), r.total);
  const auto graph = std::find_if(shares.begin(), shares.end(),
                                  [](const StageShare& s) { return std::string(s.name) == "graph"; });
  shares.erase(shares.begin(), graph);
  return shares;
}

std::string coreCsvHeader() {
  std::string header =
      "case,n,inlier_ratio,noise_m,graph_ms,second_order_ms,clique_search_ms,selection_ms,hypotheses_ms,"
      "evaluation_ms,refinement_ms,total_ms,peak_mb,graph_edges,cliques,selected_cliques,inliers,successes,"
      "repeats,incomplete_searches,max_re_deg,max_te_m,verification_ms";
  for (const StageShare& stage : coreShares(CaseResult{}))
    header += std::string(",") + stage.name + "_share_pct";
  return header + ",fgr_ms,fgr_recalled,fgr_median_re_deg,fgr_median_te_m,fgr_peak_mb";
}

void printRow(std::ostream& out, const std::string& name, int n, double ratio, const CaseResult& r,
              const PeerCase& fgr) {
  out << std::fixed << std::setprecision(2) << std::setw(14) << name << std::setw(7) << n << std::setw(6)
      << ratio * 100 << "%" << std::setw(8) << r.graph << std::setw(8) << r.second_order << std::setw(9)
      << r.cliques << std::setw(8) << r.selection << std::setw(7) << r.hypotheses << std::setw(8)
      << r.evaluation << std::setw(7) << r.refinement << std::setw(9) << r.total << std::setw(8)
      << std::setprecision(1) << r.peak_mb << std::setw(10) << std::setprecision(0) << r.clique_count
      << std::setw(7) << r.inliers << std::setw(5) << r.successes << "/" << r.repeats << std::setw(8)
      << std::setprecision(2) << r.max_re << std::setw(8) << std::setprecision(3) << r.max_te;
  if (fgr.ran)
    out << std::setprecision(2) << std::setw(9) << fgr.ms << std::setw(4) << fgr.recalled << "/"
        << fgr.repeats << std::setw(8) << fgr.median_re << std::setw(8) << std::setprecision(3)
        << fgr.median_te;
  out << "\n";
}

void printTableHeader(std::ostream& out, bool fgr) {
  out << std::setw(14) << "case" << std::setw(7) << "N" << std::setw(7) << "inl" << std::setw(8) << "graph"
      << std::setw(8) << "SOG" << std::setw(9) << "cliques" << std::setw(8) << "select" << std::setw(7)
      << "hyp" << std::setw(8) << "eval" << std::setw(7) << "refine" << std::setw(9) << "total"
      << std::setw(8) << "peakMB" << std::setw(10) << "#cliques" << std::setw(7) << "#inl" << std::setw(7)
      << "ok" << std::setw(8) << "maxRE" << std::setw(8) << "maxTE";
  if (fgr)
    out << std::setw(9) << "FGR ms" << std::setw(6) << "FGRok" << std::setw(8) << "medRE" << std::setw(8)
        << "medTE";
  out << "\n"
      << std::setw(14) << "" << std::setw(7) << "" << std::setw(7) << ""
      << "  (median ms per stage)" << std::setw(52) << "(median)" << std::setw(24) << "[deg]" << std::setw(8)
      << "[m]" << (fgr ? "   (FGR: median ms, recalled, median RE [deg] / TE [m])" : "") << "\n";
}

void printShares(std::ostream& out, const std::vector<std::pair<std::string, CaseResult>>& cases) {
  out << "\nshare of the median total per stage [%] (other: the untimed rest; medians of stages need not add "
         "up to the median total)\n"
      << std::setw(22) << "case";
  for (const StageShare& stage : coreShares(CaseResult{})) out << std::setw(8) << stage.name;
  out << std::setw(9) << "total ms"
      << "\n";
  out << std::fixed << std::setprecision(1);
  for (const auto& [name, r] : cases) {
    out << std::setw(22) << name;
    for (const StageShare& stage : coreShares(r)) out << std::setw(8) << stage.percent;
    out << std::setw(9) << std::setprecision(2) << r.total << std::setprecision(1) << "\n";
  }
}

void writeCsvRow(std::ostream& csv, const std::string& name, int n, double ratio, double noise,
                 const CaseResult& r, const PeerCase& fgr) {
  csv << name << "," << n << "," << ratio << "," << noise << "," << r.graph << "," << r.second_order << ","
      << r.cliques << "," << r.selection << "," << r.hypotheses << "," << r.evaluation << "," << r.refinement
      << "," << r.total << "," << r.peak_mb << "," << r.edges << "," << r.clique_count << "," << r.selected
      << "," << r.inliers << "," << r.successes << "," << r.repeats << "," << r.incomplete << "," << r.max_re
      << "," << r.max_te << "," << r.verification;
  for (const StageShare& stage : coreShares(r)) csv << "," << stage.percent;
  if (fgr.ran)
    csv << "," << fgr.ms << "," << fgr.recalled << "," << fgr.median_re << "," << fgr.median_te << ","
        << fgr.peak_mb << "\n";
  else
    csv << ",,,,,\n";
}

}  // namespace mac_registration
