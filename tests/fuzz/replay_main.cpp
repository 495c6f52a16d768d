// Runs a fuzz target without libFuzzer: every file of the corpus directories
// given, then seeded random mutations of them (bit flips, truncation, splices,
// byte runs), so ctest exercises the target in every build.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv) {
  std::vector<std::vector<std::uint8_t>> corpus;
  for (int i = 1; i < argc; ++i)
    for (const auto& entry : std::filesystem::directory_iterator(argv[i])) {
      std::ifstream in(entry.path(), std::ios::binary);
      corpus.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
  if (corpus.empty()) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR...\n", argv[0]);
    return 2;
  }
  for (const auto& input : corpus) LLVMFuzzerTestOneInput(input.data(), input.size());

  const char* env = std::getenv("RSD_FUZZ_ITERATIONS");
  const long iterations = env ? std::atol(env) : 200000;
  std::mt19937 rng(12345);  // fixed: a failure reproduces
  for (long n = 0; n < iterations; ++n) {
    std::vector<std::uint8_t> input = corpus[rng() % corpus.size()];
    const int edits = 1 + static_cast<int>(rng() % 8);
    for (int e = 0; e < edits && !input.empty(); ++e) {
      const std::size_t at = rng() % input.size();
      switch (rng() % 5) {
        case 0: input[at] = static_cast<std::uint8_t>(input[at] ^ (1u << (rng() % 8))); break;
        case 1: input.resize(at + 1); break;
        case 2: input.insert(input.begin() + static_cast<long>(at), static_cast<std::uint8_t>(rng())); break;
        case 3: {
          const auto& other = corpus[rng() % corpus.size()];
          input.insert(input.begin() + static_cast<long>(at), other.begin(), other.end());
          break;
        }
        default: input.insert(input.begin() + static_cast<long>(at), rng() % 64, input[at]); break;
      }
    }
    LLVMFuzzerTestOneInput(input.data(), input.size());
  }
  std::printf("%zu corpus inputs and %ld mutations: no crash\n", corpus.size(), iterations);
  return 0;
}
