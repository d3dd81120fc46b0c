#include "ros/bag/cdr_messages.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace skimap::bag {
namespace {

constexpr size_t kEncapsulation = 4;

// Reads CDR fields in order. Every getter returns false after the first error, which
// status() then describes as "<type>.<prefix><field>: ...".
class Cdr {
 public:
  Cdr(std::string_view in, absl::string_view type) : in_(in), type_(type) {
    if (in.size() < kEncapsulation) {
      Fail("", absl::StrCat("the 4-byte encapsulation header is cut at ", in.size(), " bytes"));
    } else if (in[0] != 0 || (in[1] != 0 && in[1] != 1)) {
      Fail("", absl::StrFormat("encapsulation 0x%02x%02x is not plain CDR (0x0000 big "
                               "endian, 0x0001 little endian)",
                               static_cast<uint8_t>(in[0]), static_cast<uint8_t>(in[1])));
    } else {
      big_endian_ = in[1] == 0;
      pos_ = kEncapsulation;
    }
  }

  absl::Status status() const { return status_; }
  bool ok() const { return status_.ok(); }
  // Prepended to field names in errors (e.g. "transforms[2].").
  void set_prefix(std::string prefix) { prefix_ = std::move(prefix); }

  template <typename T>
  bool Get(absl::string_view field, T* v) {
    static_assert(std::is_arithmetic_v<T>);
    if (!Align(field, sizeof(T)) || !Need(field, sizeof(T))) return false;
    uint8_t b[sizeof(T)];
    std::memcpy(b, in_.data() + pos_, sizeof(T));
    if (big_endian_) std::reverse(b, b + sizeof(T));
    std::memcpy(v, b, sizeof(T));
    pos_ += sizeof(T);
    return true;
  }

  bool String(absl::string_view field, std::string* s) {
    uint32_t n;
    if (!Get(field, &n)) return false;
    if (n > Left()) return Declared(field, n, "bytes");
    std::string_view bytes = in_.substr(pos_, n);
    pos_ += n;
    if (!bytes.empty() && bytes.back() == '\0') bytes.remove_suffix(1);
    s->assign(bytes);
    return true;
  }

  bool Bytes(absl::string_view field, std::vector<uint8_t>* v) {
    uint32_t n;
    if (!Get(field, &n)) return false;
    if (n > Left()) return Declared(field, n, "bytes");
    const auto* p = reinterpret_cast<const uint8_t*>(in_.data() + pos_);
    v->assign(p, p + n);
    pos_ += n;
    return true;
  }

  bool Doubles(absl::string_view field, std::vector<double>* v) {
    uint32_t n;
    if (!Get(field, &n)) return false;
    if (n == 0) {
      v->clear();
      return true;
    }
    if (n > Left() / 8) return Declared(field, n, "float64s");
    if (!Align(field, 8)) return false;
    if (n > Left() / 8) return Declared(field, n, "float64s");  // after the padding
    v->resize(n);
    for (double& d : *v) Get(field, &d);
    return true;
  }

  template <size_t N>
  bool Doubles(absl::string_view field, boost::array<double, N>* a) {
    for (double& d : *a) {
      if (!Get(field, &d)) return false;
    }
    return true;
  }

  // A sequence count, checked against the bytes left: each element takes >= min_size.
  bool Count(absl::string_view field, size_t min_size, uint32_t* n) {
    if (!Get(field, n)) return false;
    if (*n > Left() / min_size) {
      return Fail(field, absl::StrCat(*n, " elements declared (>= ", min_size, " bytes each), ",
                                      Left(), " bytes left"));
    }
    return true;
  }

  bool Header(absl::string_view field, std_msgs::Header* h) {
    const std::string f(field.data(), field.size());
    int32_t sec;
    uint32_t nanosec;
    if (!Get(f + ".stamp.sec", &sec) || !Get(f + ".stamp.nanosec", &nanosec)) return false;
    if (sec < 0) return Fail(f + ".stamp.sec", absl::StrCat(sec, " is negative"));
    if (nanosec >= 1000000000u) {
      return Fail(f + ".stamp.nanosec", absl::StrCat(nanosec, " is not below 1e9"));
    }
    h->seq = 0;
    h->stamp.sec = static_cast<uint32_t>(sec);
    h->stamp.nsec = nanosec;
    return String(f + ".frame_id", &h->frame_id);
  }

 private:
  size_t Left() const { return in_.size() - pos_; }
  bool Fail(absl::string_view field, absl::string_view what) {
    if (status_.ok()) {
      status_ = absl::InvalidArgumentError(
          field.empty() ? absl::StrCat(type_, ": ", what)
                        : absl::StrCat(type_, ".", prefix_, field, ": ", what));
    }
    return false;
  }
  bool Declared(absl::string_view field, uint32_t n, absl::string_view unit) {
    return Fail(field, absl::StrCat(n, " ", unit, " declared, ", Left(), " bytes left"));
  }
  bool Need(absl::string_view field, size_t n) {
    if (!status_.ok()) return false;
    if (Left() < n) return Fail(field, absl::StrCat(n, " bytes needed, ", Left(), " left"));
    return true;
  }
  bool Align(absl::string_view field, size_t n) {
    if (!status_.ok()) return false;
    const size_t pad = (n - (pos_ - kEncapsulation) % n) % n;
    if (Left() < pad) {
      return Fail(field, absl::StrCat(pad, " bytes of alignment needed, ", Left(), " left"));
    }
    pos_ += pad;
    return true;
  }

  std::string_view in_;
  absl::string_view type_;
  std::string prefix_;
  size_t pos_ = 0;
  bool big_endian_ = false;
  absl::Status status_;
};

}  // namespace

absl::Status DecodeCdr(std::string_view cdr, sensor_msgs::Image* out) {
  Cdr c(cdr, "sensor_msgs/msg/Image");
  c.Header("header", &out->header) && c.Get("height", &out->height) &&
      c.Get("width", &out->width) && c.String("encoding", &out->encoding) &&
      c.Get("is_bigendian", &out->is_bigendian) && c.Get("step", &out->step) &&
      c.Bytes("data", &out->data);
  return c.status();
}

absl::Status DecodeCdr(std::string_view cdr, sensor_msgs::CompressedImage* out) {
  Cdr c(cdr, "sensor_msgs/msg/CompressedImage");
  c.Header("header", &out->header) && c.String("format", &out->format) &&
      c.Bytes("data", &out->data);
  return c.status();
}

absl::Status DecodeCdr(std::string_view cdr, sensor_msgs::CameraInfo* out) {
  Cdr c(cdr, "sensor_msgs/msg/CameraInfo");
  auto& roi = out->roi;
  c.Header("header", &out->header) && c.Get("height", &out->height) &&
      c.Get("width", &out->width) && c.String("distortion_model", &out->distortion_model) &&
      c.Doubles("d", &out->D) && c.Doubles("k", &out->K) && c.Doubles("r", &out->R) &&
      c.Doubles("p", &out->P) && c.Get("binning_x", &out->binning_x) &&
      c.Get("binning_y", &out->binning_y) && c.Get("roi.x_offset", &roi.x_offset) &&
      c.Get("roi.y_offset", &roi.y_offset) && c.Get("roi.height", &roi.height) &&
      c.Get("roi.width", &roi.width) && c.Get("roi.do_rectify", &roi.do_rectify);
  return c.status();
}

absl::Status DecodeCdr(std::string_view cdr, tf2_msgs::TFMessage* out) {
  Cdr c(cdr, "tf2_msgs/msg/TFMessage");
  // The smallest TransformStamped: sec, nanosec, two empty strings' lengths, 7 float64s.
  constexpr size_t kMinTransform = 4 + 4 + 4 + 4 + 7 * 8;
  uint32_t n = 0;
  if (!c.Count("transforms", kMinTransform, &n)) return c.status();
  out->transforms.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    geometry_msgs::TransformStamped& t = out->transforms[i];
    geometry_msgs::Vector3& v = t.transform.translation;
    geometry_msgs::Quaternion& q = t.transform.rotation;
    c.set_prefix(absl::StrCat("transforms[", i, "]."));
    if (!(c.Header("header", &t.header) && c.String("child_frame_id", &t.child_frame_id) &&
          c.Get("transform.translation.x", &v.x) && c.Get("transform.translation.y", &v.y) &&
          c.Get("transform.translation.z", &v.z) && c.Get("transform.rotation.x", &q.x) &&
          c.Get("transform.rotation.y", &q.y) && c.Get("transform.rotation.z", &q.z) &&
          c.Get("transform.rotation.w", &q.w))) {
      break;
    }
  }
  return c.status();
}

}  // namespace skimap::bag
