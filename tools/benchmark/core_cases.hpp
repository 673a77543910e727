// The core's benchmark cases (mac_benchmark synthetic / correspondences): what a case measured, FGR beside
// it, and their table, stage shares and CSV rows.
#pragma once

#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "benchmark_table.hpp"
#include "mac_registration/core/mac_result.hpp"

namespace mac_registration {

// What one case measured: medians over the repeats, accuracy of each repeat.
struct CaseResult {
  double graph = 0, second_order = 0, cliques = 0, selection = 0, hypotheses = 0, evaluation = 0,
         refinement = 0, total = 0, verification = 0;
  double peak_mb = 0;
  double clique_count = 0, selected = 0, inliers = 0, edges = 0;
  double max_re = 0, max_te = 0;
  int successes = 0, incomplete = 0, repeats = 0;
};

// FGR on the same correspondence sets as a case's repeats (--baseline fgr): medians over the repeats.
struct PeerCase {
  bool ran = false;
  double ms = 0.0, median_re = 0.0, median_te = 0.0, peak_mb = 0.0;
  int recalled = 0, repeats = 0;
};

StageTimes stageTimesOf(const CaseResult& r);

// The core's stages (graph .. verify, other) and their shares of the median total.
std::vector<StageShare> coreShares(const CaseResult& r);

// The CSV's columns; writeCsvRow writes one row of them.
std::string coreCsvHeader();
void writeCsvRow(std::ostream& csv, const std::string& name, int n, double ratio, double noise,
                 const CaseResult& r, const PeerCase& fgr);

// The table printed as the cases run: its header, one row a case (FGR's columns when it ran).
void printTableHeader(std::ostream& out, bool fgr);
void printRow(std::ostream& out, const std::string& name, int n, double ratio, const CaseResult& r,
              const PeerCase& fgr);

// The median time of each core stage as a share of the median total, one line per case.
void printShares(std::ostream& out, const std::vector<std::pair<std::string, CaseResult>>& cases);

}  // namespace mac_registration
