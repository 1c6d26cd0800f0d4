// What `mrd simulate --json` computes, timed in C++: the reference the Python module's overhead is
// measured against (python/bench/simulate.py; docs/benchmarks.md "Python module").
// Usage: bench_python_simulate MODEL.json DATA.csv [--benchmark_* flags]
#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>
#include <vector>

#include "mrd/host/csv.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/model_judge.hpp"

namespace {

std::string g_model, g_data;

// The command's work after its arguments: the model file and the data file read, the free run,
// the envelope check and the JSON it prints.
void BM_SimulateCommand(benchmark::State& state) {
  for (auto _ : state) {
    const mrd::host::ModelFile mf = mrd::host::LoadModelFile(g_model);
    const mrd::host::DataSet data = mrd::host::ReadCsv(g_data, mf.spec.Signals());
    std::vector<double> ysim;
    const mrd::host::SimMetrics m = mrd::host::SimulateModel(mf, mf.selected, data, &ysim);
    const auto env = mrd::host::CheckEnvelope(mf, data);
    benchmark::DoNotOptimize(mrd::host::EnvelopeWarnings(g_model, g_data, env));
    nlohmann::json j = mrd::host::MetricsJson(mf, m);
    j["envelope"] = mrd::host::EnvelopeJson(env);
    benchmark::DoNotOptimize(j.dump());
  }
}
BENCHMARK(BM_SimulateCommand)->Unit(benchmark::kMillisecond);

// The same on data already in memory (the model loaded once): what Model.simulate does with
// arrays, but for converting them: the data set checked (MakeDataSet), the free run, the
// envelope check, the metrics.
void BM_SimulateInMemory(benchmark::State& state) {
  const mrd::host::ModelFile mf = mrd::host::LoadModelFile(g_model);
  const mrd::host::DataSet file = mrd::host::ReadCsv(g_data, mf.spec.Signals());
  for (auto _ : state) {
    const mrd::host::DataSet data =
        mrd::host::MakeDataSet("data", file.names, file.columns, mf.spec.Signals());
    std::vector<double> ysim;
    const mrd::host::SimMetrics m = mrd::host::SimulateModel(mf, mf.selected, data, &ysim);
    const auto env = mrd::host::CheckEnvelope(mf, data);
    nlohmann::json j = mrd::host::MetricsJson(mf, m);
    j["envelope"] = mrd::host::EnvelopeJson(env);
    benchmark::DoNotOptimize(j);
    benchmark::DoNotOptimize(ysim.data());
  }
  state.counters["samples"] = static_cast<double>(file.rows());
}
BENCHMARK(BM_SimulateInMemory)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s MODEL.json DATA.csv [--benchmark_* flags]\n", argv[0]);
    return 2;
  }
  g_model = argv[1];
  g_data = argv[2];
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
