// Reader of the terrasph LSTM model file (format version 1, docs/lstm_format.md).
//
// Header-only, C++17, no dependencies beyond the standard library. The reader checks every
// field against its allowed range and the byte budget of the file before it allocates, so a
// truncated, corrupted or hostile file raises FormatError and never crashes.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace terrasph {
namespace lstm {

/// Version of the file format written by terrasph.surrogate.export and read here.
constexpr std::uint32_t kFormatVersion = 1;
/// First eight bytes of every model file.
constexpr char kMagic[8] = {'T', 'S', 'P', 'H', 'L', 'S', 'T', 'M'};

/// Limits on the sizes a file may declare (checked before any allocation).
constexpr std::uint32_t kMaxLayers = 64;
constexpr std::uint32_t kMaxSize = 1u << 16;         // input, hidden and output sizes
constexpr std::uint32_t kMaxNameBytes = 4096;        // one feature or target name
constexpr std::uint32_t kMaxMetadataBytes = 1u << 24;  // metadata JSON text

/// Error raised for any file that is not a valid model file.
class FormatError : public std::runtime_error {
 public:
  explicit FormatError(const std::string& what) : std::runtime_error(what) {}
};

/// Cell equations of the recurrent layers.
enum class CellType : std::uint32_t {
  Standard = 0,  ///< PyTorch nn.LSTM
  Peephole = 1,  ///< dissertation Eq. 4.9-4.13 (peephole matrices W_ci, W_cf, W_co)
};

inline const char* cell_type_name(CellType t) {
  return t == CellType::Standard ? "standard" : "peephole";
}

/// One recurrent layer as stored in the file (float64, row-major, PyTorch gate order i,f,g,o).
struct LayerData {
  std::uint32_t input_size = 0;
  std::uint32_t hidden_size = 0;
  std::vector<double> w_ih;  // (4H, input_size)
  std::vector<double> w_hh;  // (4H, H)
  std::vector<double> bias;  // (4H,) = bias_ih + bias_hh
  std::vector<double> w_ci;  // (H, H), peephole only (Eq. 4.9)
  std::vector<double> w_cf;  // (H, H), peephole only (Eq. 4.10)
  std::vector<double> w_co;  // (H, H), peephole only (Eq. 4.12)
};

/// Whole content of a model file, in float64.
struct ModelData {
  std::uint32_t version = kFormatVersion;
  CellType cell = CellType::Standard;
  std::uint32_t input_size = 0;
  std::uint32_t output_size = 0;
  std::vector<std::string> feature_names;
  std::vector<std::string> target_names;
  std::string metadata;  // JSON text, informative only
  std::vector<double> input_mean, input_scale;    // x_n = (x - mean) / scale
  std::vector<double> output_mean, output_scale;  // y = y_n * scale + mean
  std::vector<LayerData> layers;
  std::vector<double> w_out;  // (O, H_last)
  std::vector<double> b_out;  // (O,)
};

/// CRC-32 (IEEE 802.3, as zlib.crc32) of a byte range.
inline std::uint32_t crc32(const unsigned char* data, std::size_t n) {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    table[i] = c;
  }
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) crc = table[(crc ^ data[i]) & 0xFFu] ^ (crc >> 8);
  return crc ^ 0xFFFFFFFFu;
}

namespace detail {

/// Bounds-checked little-endian cursor over the file's bytes.
class Reader {
 public:
  Reader(const unsigned char* data, std::size_t size) : data_(data), size_(size) {}

  std::size_t offset() const { return pos_; }
  std::size_t remaining() const { return size_ - pos_; }

  void need(std::size_t n, const char* what) const {
    if (n > remaining()) {
      throw FormatError("LSTM model file truncated: field '" + std::string(what) + "' needs " +
                        std::to_string(n) + " bytes at offset " + std::to_string(pos_) +
                        " but only " + std::to_string(remaining()) + " remain");
    }
  }

  void skip(std::size_t n, const char* what) {
    need(n, what);
    pos_ += n;
  }

  std::uint32_t u32(const char* what) {
    need(4, what);
    std::uint32_t v = 0;
    for (int k = 3; k >= 0; --k) v = (v << 8) | data_[pos_ + static_cast<std::size_t>(k)];
    pos_ += 4;
    return v;
  }

  std::uint32_t u32_in(const char* what, std::uint32_t lo, std::uint32_t hi) {
    const std::size_t at = pos_;
    const std::uint32_t v = u32(what);
    if (v < lo || v > hi) {
      throw FormatError("LSTM model file: field '" + std::string(what) + "' = " +
                        std::to_string(v) + " at offset " + std::to_string(at) +
                        " is outside the allowed range [" + std::to_string(lo) + ", " +
                        std::to_string(hi) + "]");
    }
    return v;
  }

  std::string str(const char* what, std::uint32_t max_bytes) {
    const std::uint32_t n = u32_in(what, 0, max_bytes);
    need(n, what);
    std::string s(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return s;
  }

  /// n float64 values; all must be finite.
  std::vector<double> f64(std::size_t n, const std::string& what) {
    if (n > remaining() / 8) {
      throw FormatError("LSTM model file truncated: field '" + what + "' needs " +
                        std::to_string(n) + " float64 values at offset " + std::to_string(pos_));
    }
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) {
      std::uint64_t bits = 0;
      for (int k = 7; k >= 0; --k) bits = (bits << 8) | data_[pos_ + static_cast<std::size_t>(k)];
      double d = 0.0;
      std::memcpy(&d, &bits, sizeof d);
      if (!std::isfinite(d)) {
        throw FormatError("LSTM model file: non-finite value in '" + what + "' at index " +
                          std::to_string(i) + " (offset " + std::to_string(pos_) + ")");
      }
      v[i] = d;
      pos_ += 8;
    }
    return v;
  }

 private:
  const unsigned char* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace detail

/// Parse a model file held in memory. Throws FormatError with the offending field.
inline ModelData parse_model(const unsigned char* data, std::size_t size) {
  constexpr std::size_t kMinSize = 8 + 4 + 4;  // magic, version, trailing CRC
  if (data == nullptr || size < kMinSize) {
    throw FormatError("LSTM model file too short (" + std::to_string(size) +
                      " bytes): not a terrasph LSTM model");
  }
  if (std::memcmp(data, kMagic, sizeof kMagic) != 0) {
    throw FormatError("not a terrasph LSTM model file (magic bytes 'TSPHLSTM' missing)");
  }
  detail::Reader r(data, size - 4);  // the last 4 bytes hold the CRC
  r.skip(sizeof kMagic, "magic");
  ModelData m;
  m.version = r.u32("version");
  if (m.version != kFormatVersion) {
    throw FormatError("LSTM model file has format version " + std::to_string(m.version) +
                      "; this reader supports version " + std::to_string(kFormatVersion));
  }
  std::uint32_t stored_crc = 0;
  for (int k = 3; k >= 0; --k) stored_crc = (stored_crc << 8) | data[size - 4 + static_cast<std::size_t>(k)];
  const std::uint32_t crc = crc32(data, size - 4);
  if (crc != stored_crc) {
    throw FormatError("LSTM model file corrupted or truncated: CRC-32 mismatch (stored " +
                      std::to_string(stored_crc) + ", computed " + std::to_string(crc) + ")");
  }
  m.cell = static_cast<CellType>(r.u32_in("cell_type", 0, 1));
  m.input_size = r.u32_in("input_size", 1, kMaxSize);
  m.output_size = r.u32_in("output_size", 1, kMaxSize);
  const std::uint32_t n_layers = r.u32_in("num_layers", 1, kMaxLayers);
  std::vector<std::uint32_t> hidden(n_layers);
  for (auto& h : hidden) h = r.u32_in("hidden_size", 1, kMaxSize);

  // Byte budget of the numeric part, checked before allocating (sizes <= 2^16: no overflow).
  const bool peep = m.cell == CellType::Peephole;
  std::uint64_t n_values = 2ull * m.input_size + 2ull * m.output_size;
  std::uint64_t in = m.input_size;
  for (std::uint32_t h : hidden) {
    n_values += 4ull * h * (in + h) + 4ull * h + (peep ? 3ull * h * h : 0ull);
    in = h;
  }
  n_values += static_cast<std::uint64_t>(m.output_size) * (in + 1);
  if (n_values * 8 > r.remaining()) {
    throw FormatError("LSTM model file truncated or sizes corrupted: the declared sizes need " +
                      std::to_string(n_values * 8) + " bytes of weights but only " +
                      std::to_string(r.remaining()) + " remain");
  }

  for (std::uint32_t i = 0; i < m.input_size; ++i) m.feature_names.push_back(r.str("feature_name", kMaxNameBytes));
  for (std::uint32_t i = 0; i < m.output_size; ++i) m.target_names.push_back(r.str("target_name", kMaxNameBytes));
  m.metadata = r.str("metadata", kMaxMetadataBytes);
  if (n_values * 8 != r.remaining()) {
    throw FormatError("LSTM model file truncated or sizes corrupted: " +
                      std::to_string(r.remaining()) +
                      " bytes of weights found where the declared sizes need exactly " +
                      std::to_string(n_values * 8));
  }
  m.input_mean = r.f64(m.input_size, "input_mean");
  m.input_scale = r.f64(m.input_size, "input_scale");
  m.output_mean = r.f64(m.output_size, "output_mean");
  m.output_scale = r.f64(m.output_size, "output_scale");
  for (double s : m.input_scale)
    if (!(s > 0.0)) throw FormatError("LSTM model file: input_scale must be > 0");
  for (double s : m.output_scale)
    if (!(s > 0.0)) throw FormatError("LSTM model file: output_scale must be > 0");

  in = m.input_size;
  for (std::uint32_t l = 0; l < n_layers; ++l) {
    const std::string tag = "layer " + std::to_string(l) + " ";
    LayerData L;
    L.input_size = static_cast<std::uint32_t>(in);
    L.hidden_size = hidden[l];
    const std::size_t H = hidden[l];
    L.w_ih = r.f64(4 * H * in, tag + "weight_ih");
    L.w_hh = r.f64(4 * H * H, tag + "weight_hh");
    L.bias = r.f64(4 * H, tag + "bias");
    if (peep) {
      L.w_ci = r.f64(H * H, tag + "weight_ci");
      L.w_cf = r.f64(H * H, tag + "weight_cf");
      L.w_co = r.f64(H * H, tag + "weight_co");
    }
    m.layers.push_back(std::move(L));
    in = H;
  }
  m.w_out = r.f64(static_cast<std::size_t>(m.output_size) * in, "head weight");
  m.b_out = r.f64(m.output_size, "head bias");
  return m;
}

/// Read and parse a model file from disk. Throws FormatError (also for I/O failures).
inline ModelData read_model_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw FormatError("cannot open LSTM model file '" + path + "'");
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)),
                                   std::istreambuf_iterator<char>());
  if (f.bad()) throw FormatError("error while reading LSTM model file '" + path + "'");
  try {
    return parse_model(bytes.data(), bytes.size());
  } catch (const FormatError& e) {
    throw FormatError(path + ": " + e.what());
  }
}

}  // namespace lstm
}  // namespace terrasph
