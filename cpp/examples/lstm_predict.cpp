// Standalone use of the terrasph LSTM engine from C++ (no Python): stream a CSV of inputs
// through an exported model one time step at a time, as robot control code would.
//
//   lstm_predict MODEL.tslstm INPUT.csv [--float32]
//
// INPUT.csv: one time step per row, the model's features as columns in the model's order; an
// optional first row with the feature names is skipped. Output on stdout: a header with the
// target names, then one row of raw targets per time step. Errors go to stderr, exit code 1.
#include <terrasph/lstm.hpp>

#include <cstdio>
#include <exception>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace {

/// Parse one CSV row of numbers; returns false for a non-numeric (header) row.
bool parse_row(const std::string& line, std::vector<double>& out) {
  out.clear();
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) {
    std::size_t used = 0;
    try {
      out.push_back(std::stod(cell, &used));
    } catch (const std::exception&) {
      return false;
    }
    while (used < cell.size() && (cell[used] == ' ' || cell[used] == '\r')) ++used;
    if (used != cell.size()) return false;
  }
  return true;
}

template <typename Scalar>
int run(const std::string& model_path, const std::string& input_path) {
  using terrasph::lstm::Model;
  using terrasph::lstm::Stream;
  const std::shared_ptr<const Model<Scalar>> model = Model<Scalar>::load(model_path);
  Stream<Scalar> stream(model);  // all buffers allocated here; step() does not allocate

  std::ifstream in(input_path);
  if (!in) throw std::runtime_error("cannot open input file '" + input_path + "'");
  const auto ni = static_cast<std::size_t>(model->input_size());
  const auto no = static_cast<std::size_t>(model->output_size());
  std::vector<Scalar> x(ni), y(no);
  std::vector<double> row;

  for (std::size_t k = 0; k < no; ++k) std::cout << (k ? "," : "") << model->target_names()[k];
  std::cout << '\n';
  std::string line;
  std::size_t line_no = 0, steps = 0;
  char buf[64];
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line == "\r") continue;
    if (!parse_row(line, row)) {
      if (steps == 0 && line_no == 1) continue;  // header row
      throw std::runtime_error("line " + std::to_string(line_no) + ": not a row of numbers");
    }
    if (row.size() != ni) {
      throw std::runtime_error("line " + std::to_string(line_no) + ": expected " +
                               std::to_string(ni) + " columns, got " + std::to_string(row.size()));
    }
    for (std::size_t j = 0; j < ni; ++j) x[j] = static_cast<Scalar>(row[j]);
    stream.step(x.data(), y.data());
    for (std::size_t k = 0; k < no; ++k) {
      std::snprintf(buf, sizeof buf, "%.17g", static_cast<double>(y[k]));
      std::cout << (k ? "," : "") << buf;
    }
    std::cout << '\n';
    ++steps;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4 || (argc == 4 && std::string(argv[3]) != "--float32")) {
    std::cerr << "usage: " << argv[0] << " MODEL.tslstm INPUT.csv [--float32]\n";
    return 2;
  }
  try {
    return argc == 4 ? run<float>(argv[1], argv[2]) : run<double>(argv[1], argv[2]);
  } catch (const std::exception& e) {
    std::cerr << "lstm_predict: error: " << e.what() << '\n';
    return 1;
  }
}
