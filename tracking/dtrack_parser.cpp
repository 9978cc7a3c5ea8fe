#include "tracking/dtrack_parser.h"

#include <charconv>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <utility>

namespace gs::tracking {

const char* LineName(ELine line) {
  static const char* const kNames[] = {"fr",   "ts",    "ts2", "6dcal", "6d", "6dcov", "6df", "6df2", "6dmt",
                                       "6dmt2", "6dmtr", "glcal", "gl", "6dj", "6di", "3d", "st"};
  const int i = static_cast<int>(line);
  return i >= 0 && i < static_cast<int>(ELine::Count) ? kNames[i] : "?";
}

const char* ErrorName(EParseError e) {
  static const char* const kNames[] = {"oversized", "syntax",        "bad_number",    "non_finite",  "bad_count",
                                       "missing_block", "bad_value", "zero_rotation", "bad_rotation"};
  const int i = static_cast<int>(e);
  return i >= 0 && i < static_cast<int>(EParseError::Count) ? kNames[i] : "?";
}

uint64_t ParseStats::TotalErrors() const {
  uint64_t n = 0;
  for (uint64_t e : errors) n += e;
  return n;
}

Mat3 RotationFromColumns(const double* b) {
  Mat3 R;
  R << b[0], b[3], b[6], b[1], b[4], b[7], b[2], b[5], b[8];
  return R;
}

Mat3 RotationFromEulerDeg(double eta, double theta, double phi) {
  const double k = M_PI / 180.0;
  return (Eigen::AngleAxisd(eta * k, Vec3::UnitX()) * Eigen::AngleAxisd(theta * k, Vec3::UnitY()) *
          Eigen::AngleAxisd(phi * k, Vec3::UnitZ()))
      .toRotationMatrix();
}

namespace {

template <class T>
const T* FindById(const std::vector<T>& v, int id) {
  for (const T& x : v)
    if (x.id == id) return &x;
  return nullptr;
}

constexpr int kMaxTokens = 64;        // numbers per block
constexpr int64_t kMaxId = 1 << 30;   // IDs are small non-negative integers

bool IsSpace(char c) { return c == ' ' || c == '\t'; }

}  // namespace

const Body6d* DTrackFrame::FindBody(int id) const { return FindById(bodies, id); }
const Hand* DTrackFrame::FindHand(int id) const { return FindById(hands, id); }
const Flystick* DTrackFrame::FindFlystick(int id) const { return FindById(flysticks, id); }
const MeasurementTool* DTrackFrame::FindTool(int id) const { return FindById(tools, id); }
const Marker* DTrackFrame::FindMarker(int id) const { return FindById(markers, id); }
const InertialBody* DTrackFrame::FindInertial(int id) const { return FindById(inertials, id); }

void DTrackFrame::Clear() {
  present = 0;
  frame = 0;
  timestamp = -1.0;
  ts2_sec = ts2_usec = latency_us = 0;
  cal_bodies = cal_hands = cal_flysticks = cal_tools = cal_tool_refs = cal_humans = 0;
  bodies.clear();
  covariances.clear();
  flysticks.clear();
  tools.clear();
  tool_refs.clear();
  hands.clear();
  humans.clear();
  human_joints.clear();
  inertials.clear();
  markers.clear();
  status.has_general = status.has_messages = false;
  status.num_cameras = status.num_bodies = status.num_markers = 0;
  status.camera_errors = status.camera_warnings = status.other_errors = status.other_warnings = status.info = 0;
  status.cameras.clear();
}

// Reads one bounded line: header tokens, then blocks of numbers. The first
// problem is recorded (category and message) and every later call fails fast.
struct LineReader {
  const char* p = nullptr;
  const char* end = nullptr;
  int line_no = 0;
  ELine type = ELine::Count;
  int object = -1;  // index of the object being read, for messages
  bool failed = false;
  EParseError category = EParseError::Syntax;
  char message[160] = {};
  std::string_view tok[kMaxTokens];
  int ntok = 0;
  double rotation_tolerance = 1e-2;

  bool Fail(EParseError e, const char* fmt, ...) __attribute__((format(printf, 3, 4))) {
    if (failed) return false;
    failed = true;
    category = e;
    va_list ap;
    va_start(ap, fmt);
    std::vsnprintf(message, sizeof(message), fmt, ap);
    va_end(ap);
    return false;
  }

  void SkipSpace() {
    while (p < end && IsSpace(*p)) ++p;
  }

  // a token before the first block (a count)
  bool HeaderToken(std::string_view* out, const char* what) {
    if (failed) return false;
    SkipSpace();
    const char* s = p;
    while (p < end && !IsSpace(*p) && *p != '[' && *p != ']') ++p;
    if (p == s) return Fail(EParseError::Syntax, "missing %s", what);
    *out = std::string_view(s, static_cast<size_t>(p - s));
    return true;
  }

  bool HeaderInt(int64_t* out, const char* what, int64_t lo, int64_t hi, EParseError range_error) {
    std::string_view t;
    if (!HeaderToken(&t, what)) return false;
    if (!ToInt(t, out, what)) return false;
    if (*out < lo || *out > hi)
      return Fail(range_error, "%s %lld out of range [%lld, %lld]", what, static_cast<long long>(*out),
                  static_cast<long long>(lo), static_cast<long long>(hi));
    return true;
  }

  bool HeaderNumber(double* out, const char* what) {
    std::string_view t;
    if (!HeaderToken(&t, what)) return false;
    return ToDouble(t, out, what);
  }

  // the next block: "[" numbers "]", at least min_count of them
  bool Block(int min_count, const char* what) {
    if (failed) return false;
    SkipSpace();
    if (p >= end) return Fail(EParseError::MissingBlock, "%s block missing (the line ends)", what);
    if (*p != '[') return Fail(EParseError::Syntax, "'[' expected before the %s block", what);
    ++p;
    ntok = 0;
    for (;;) {
      SkipSpace();
      if (p >= end) return Fail(EParseError::Syntax, "%s block not closed by ']'", what);
      if (*p == ']') {
        ++p;
        break;
      }
      if (*p == '[') return Fail(EParseError::Syntax, "'[' inside the %s block", what);
      const char* s = p;
      while (p < end && !IsSpace(*p) && *p != ']' && *p != '[') ++p;
      if (ntok == kMaxTokens) return Fail(EParseError::BadCount, "%s block holds more than %d numbers", what, kMaxTokens);
      tok[ntok++] = std::string_view(s, static_cast<size_t>(p - s));
    }
    if (ntok < min_count)
      return Fail(EParseError::MissingBlock, "%s block has %d numbers, %d needed", what, ntok, min_count);
    return true;
  }

  bool ToDouble(std::string_view t, double* out, const char* what) {
    if (failed) return false;
    const char* b = t.data();
    const char* e = b + t.size();
    if (b < e && *b == '+') ++b;  // strtod accepts a leading '+'; from_chars does not
    if (b < e && (*b == '+' || *b == '-') && b > t.data())
      return Fail(EParseError::BadNumber, "%s '%.*s' is not a number", what, static_cast<int>(t.size()), t.data());
    double v = 0.0;
    const auto r = std::from_chars(b, e, v, std::chars_format::general);
    if (r.ec == std::errc::result_out_of_range)
      return Fail(EParseError::NonFinite, "%s '%.*s' is out of the double range", what, static_cast<int>(t.size()),
                  t.data());
    if (r.ec != std::errc() || r.ptr != e || b == e)
      return Fail(EParseError::BadNumber, "%s '%.*s' is not a number", what, static_cast<int>(t.size()), t.data());
    if (!std::isfinite(v))
      return Fail(EParseError::NonFinite, "%s '%.*s' is not finite", what, static_cast<int>(t.size()), t.data());
    *out = v;
    return true;
  }

  bool ToInt(std::string_view t, int64_t* out, const char* what) {
    if (failed) return false;
    const char* b = t.data();
    const char* e = b + t.size();
    if (b < e && *b == '+') ++b;
    if (b < e && (*b == '+' || *b == '-') && b > t.data())
      return Fail(EParseError::BadNumber, "%s '%.*s' is not an integer", what, static_cast<int>(t.size()), t.data());
    int64_t v = 0;
    const auto r = std::from_chars(b, e, v, 10);
    if (r.ec == std::errc::result_out_of_range)
      return Fail(EParseError::BadValue, "%s '%.*s' is out of range", what, static_cast<int>(t.size()), t.data());
    if (r.ec != std::errc() || r.ptr != e || b == e)
      return Fail(EParseError::BadNumber, "%s '%.*s' is not an integer", what, static_cast<int>(t.size()), t.data());
    *out = v;
    return true;
  }

  // token i of the current block
  bool Num(int i, double* out, const char* what) { return ToDouble(tok[i], out, what); }
  bool Int(int i, int64_t* out, const char* what, int64_t lo, int64_t hi) {
    if (!ToInt(tok[i], out, what)) return false;
    if (*out < lo || *out > hi)
      return Fail(EParseError::BadValue, "%s %lld out of range [%lld, %lld]", what, static_cast<long long>(*out),
                  static_cast<long long>(lo), static_cast<long long>(hi));
    return true;
  }
  // every token of the block must be a finite number (extras are ignored but checked)
  bool AllFinite(int from, const char* what) {
    double v = 0.0;
    for (int i = from; i < ntok; ++i)
      if (!ToDouble(tok[i], &v, what)) return false;
    return true;
  }

  bool Id(int i, int* out) {
    int64_t v = 0;
    if (!Int(i, &v, "id", 0, kMaxId)) return false;
    *out = static_cast<int>(v);
    return true;
  }
  bool Quality(int i, double* out) {
    if (!Num(i, out, "quality")) return false;
    if (*out < -1.0 || *out > 1.0) return Fail(EParseError::BadValue, "quality %g outside [-1, 1]", *out);
    return true;
  }

  // "[x y z ...]": at least 3 values; up to n_out kept
  bool Position(Vec3* pos, double* extra = nullptr, int n_extra = 0, bool* has_extra = nullptr) {
    if (!Block(3, "position")) return false;
    double v[3];
    for (int i = 0; i < 3; ++i)
      if (!Num(i, &v[i], "position")) return false;
    *pos = Vec3(v[0], v[1], v[2]);
    if (has_extra) *has_extra = false;
    if (extra && ntok >= 3 + n_extra) {
      for (int i = 0; i < n_extra; ++i)
        if (!Num(3 + i, &extra[i], "position block")) return false;
      if (has_extra) *has_extra = true;
    }
    return AllFinite(3, "position block");
  }

  // "[b0 .. b8]", checked when the object is tracked
  bool Rotation(Mat3* R, bool tracked) {
    if (!Block(9, "rotation")) return false;
    double b[9];
    for (int i = 0; i < 9; ++i)
      if (!Num(i, &b[i], "rotation")) return false;
    if (!AllFinite(9, "rotation block")) return false;
    *R = RotationFromColumns(b);
    if (!tracked) return true;
    if (R->cwiseAbs().maxCoeff() == 0.0) return Fail(EParseError::ZeroRotation, "all-zero rotation on a tracked object");
    const double err = (R->transpose() * *R - Mat3::Identity()).cwiseAbs().maxCoeff();
    if (!(err <= rotation_tolerance) || R->determinant() < 0.0)
      return Fail(EParseError::BadRotation, "rotation of a tracked object is not orthonormal (error %.3g)", err);
    return true;
  }

  // the object count: at most one object per 4 characters left on the line
  bool Count(int64_t* n, const char* what) {
    const int64_t room = (end - p) / 4 + 1;
    if (!HeaderInt(n, what, 0, 1 << 24, EParseError::BadCount)) return false;
    if (*n > room)
      return Fail(EParseError::MissingBlock, "%s %lld is larger than the line could hold", what,
                  static_cast<long long>(*n));
    return true;
  }

  // what remains after the expected blocks
  bool Trailing() {
    SkipSpace();
    return p < end;
  }
};

namespace {

template <class T>
bool DuplicateId(const std::vector<T>& v, int id) {
  for (size_t i = 0; i + 1 < v.size(); ++i)
    if (v[i].id == id) return true;
  return false;
}

bool ParseBodies(LineReader& r, std::vector<Body6d>* out, bool euler) {
  int64_t n = 0;
  if (!r.Count(&n, "body count")) return false;
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    Body6d b;
    if (!r.Block(2, "id/quality") || !r.Id(0, &b.id) || !r.Quality(1, &b.quality) || !r.AllFinite(2, "id block"))
      return false;
    if (!r.Position(&b.position, euler ? b.euler_deg.data() : nullptr, euler ? 3 : 0, &b.has_euler)) return false;
    if (!r.Rotation(&b.rotation, b.tracked())) return false;
    out->push_back(b);
    if (DuplicateId(*out, b.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", b.id);
  }
  return true;
}

bool ParseCovariances(LineReader& r, std::vector<Covariance6d>* out) {
  int64_t n = 0;
  if (!r.Count(&n, "count")) return false;
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    Covariance6d c;
    if (!r.Block(4, "id/reference") || !r.Id(0, &c.id)) return false;
    for (int i = 0; i < 3; ++i)
      if (!r.Num(1 + i, &c.reference[i], "reference point")) return false;
    if (!r.Block(21, "covariance")) return false;
    for (int i = 0; i < 21; ++i)
      if (!r.Num(i, &c.upper[i], "covariance")) return false;
    out->push_back(c);
    if (DuplicateId(*out, c.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", c.id);
  }
  return true;
}

bool ParseFlysticks1(LineReader& r, std::vector<Flystick>* out) {
  int64_t n = 0;
  if (!r.Count(&n, "flystick count")) return false;
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    Flystick f;
    int64_t bt = 0;
    if (!r.Block(3, "id/quality/buttons") || !r.Id(0, &f.id) || !r.Quality(1, &f.quality) ||
        !r.Int(2, &bt, "buttons", 0, 255))
      return false;
    f.num_buttons = 8;
    f.num_analogs = 2;
    f.buttons = static_cast<uint32_t>(bt);
    // hat switch bits as the joystick
    f.analogs[0] = (bt & 0x20) ? -1.0 : ((bt & 0x80) ? 1.0 : 0.0);
    f.analogs[1] = (bt & 0x10) ? -1.0 : ((bt & 0x40) ? 1.0 : 0.0);
    if (!r.Position(&f.position) || !r.Rotation(&f.rotation, f.tracked())) return false;
    out->push_back(f);
    if (DuplicateId(*out, f.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", f.id);
  }
  return true;
}

bool ParseFlysticks2(LineReader& r, std::vector<Flystick>* out, int* ncal) {
  int64_t cal = 0, n = 0;
  if (!r.HeaderInt(&cal, "calibrated count", 0, 1 << 24, EParseError::BadCount) || !r.Count(&n, "flystick count"))
    return false;
  *ncal = static_cast<int>(cal);
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    Flystick f;
    int64_t nbt = 0, nct = 0;
    if (!r.Block(4, "id/quality/counts") || !r.Id(0, &f.id) || !r.Quality(1, &f.quality)) return false;
    if (!r.ToInt(r.tok[2], &nbt, "button count") || !r.ToInt(r.tok[3], &nct, "analog count")) return false;
    if (nbt < 0 || nbt > Flystick::kMaxButtons)
      return r.Fail(EParseError::BadCount, "button count %lld out of [0, %d]", static_cast<long long>(nbt),
                    Flystick::kMaxButtons);
    if (nct < 0 || nct > Flystick::kMaxAnalogs)
      return r.Fail(EParseError::BadCount, "analog count %lld out of [0, %d]", static_cast<long long>(nct),
                    Flystick::kMaxAnalogs);
    f.num_buttons = static_cast<int>(nbt);
    f.num_analogs = static_cast<int>(nct);
    if (!r.Position(&f.position) || !r.Rotation(&f.rotation, f.tracked())) return false;
    const int words = (f.num_buttons + 31) / 32;
    if (!r.Block(words + f.num_analogs, "buttons/analogs")) return false;
    for (int w = 0; w < words; ++w) {
      int64_t bits = 0;
      if (!r.Int(w, &bits, "button word", 0, (int64_t{1} << f.num_buttons) - 1)) return false;
      f.buttons = static_cast<uint32_t>(bits);
    }
    for (int a = 0; a < f.num_analogs; ++a)
      if (!r.Num(words + a, &f.analogs[a], "analog")) return false;
    out->push_back(f);
    if (DuplicateId(*out, f.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", f.id);
  }
  return true;
}

bool ParseTools1(LineReader& r, std::vector<MeasurementTool>* out) {
  int64_t n = 0;
  if (!r.Count(&n, "tool count")) return false;
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    MeasurementTool t;
    int64_t bt = 0;
    if (!r.Block(3, "id/quality/buttons") || !r.Id(0, &t.id) || !r.Quality(1, &t.quality) ||
        !r.Int(2, &bt, "buttons", 0, 15))
      return false;
    t.num_buttons = 4;
    t.buttons = static_cast<uint32_t>(bt);
    if (!r.Position(&t.position) || !r.Rotation(&t.rotation, t.tracked())) return false;
    out->push_back(t);
    if (DuplicateId(*out, t.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", t.id);
  }
  return true;
}

bool ParseTools2(LineReader& r, std::vector<MeasurementTool>* out, int* ncal) {
  int64_t cal = 0, n = 0;
  if (!r.HeaderInt(&cal, "calibrated count", 0, 1 << 24, EParseError::BadCount) || !r.Count(&n, "tool count"))
    return false;
  *ncal = static_cast<int>(cal);
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    MeasurementTool t;
    int64_t nbt = 0;
    if (!r.Block(4, "id/quality/buttons/radius") || !r.Id(0, &t.id) || !r.Quality(1, &t.quality) ||
        !r.ToInt(r.tok[2], &nbt, "button count") || !r.Num(3, &t.tip_radius, "tip radius"))
      return false;
    if (nbt < 0 || nbt > MeasurementTool::kMaxButtons)
      return r.Fail(EParseError::BadCount, "button count %lld out of [0, %d]", static_cast<long long>(nbt),
                    MeasurementTool::kMaxButtons);
    if (t.tip_radius < 0.0) return r.Fail(EParseError::BadValue, "negative tip radius %g", t.tip_radius);
    t.num_buttons = static_cast<int>(nbt);
    if (!r.Position(&t.position) || !r.Rotation(&t.rotation, t.tracked())) return false;
    const int words = (t.num_buttons + 31) / 32;
    if (!r.Block(words, "buttons")) return false;
    for (int w = 0; w < words; ++w) {
      int64_t bits = 0;
      if (!r.Int(w, &bits, "button word", 0, UINT32_MAX)) return false;
      t.buttons = static_cast<uint32_t>(bits);
    }
    double s[6];
    if (!r.Block(6, "tip covariance")) return false;
    for (int i = 0; i < 6; ++i)
      if (!r.Num(i, &s[i], "tip covariance")) return false;
    t.has_covariance = true;
    t.tip_covariance << s[0], s[1], s[2], s[1], s[3], s[4], s[2], s[4], s[5];
    out->push_back(t);
    if (DuplicateId(*out, t.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", t.id);
  }
  return true;
}

bool ParseToolRefs(LineReader& r, std::vector<Body6d>* out, int* ncal) {
  int64_t cal = 0, n = 0;
  if (!r.HeaderInt(&cal, "calibrated count", 0, 1 << 24, EParseError::BadCount) || !r.Count(&n, "count"))
    return false;
  *ncal = static_cast<int>(cal);
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    Body6d b;
    if (!r.Block(2, "id/quality") || !r.Id(0, &b.id) || !r.Quality(1, &b.quality)) return false;
    if (!r.Position(&b.position) || !r.Rotation(&b.rotation, b.tracked())) return false;
    out->push_back(b);
    if (DuplicateId(*out, b.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", b.id);
  }
  return true;
}

bool ParseHands(LineReader& r, std::vector<Hand>* out) {
  int64_t n = 0;
  if (!r.Count(&n, "hand count")) return false;
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    Hand h;
    int64_t lr = 0, nf = 0;
    if (!r.Block(4, "id/quality/lr/fingers") || !r.Id(0, &h.id) || !r.Quality(1, &h.quality) ||
        !r.Int(2, &lr, "left/right", 0, 1) || !r.ToInt(r.tok[3], &nf, "finger count"))
      return false;
    if (nf < 0 || nf > Hand::kMaxFingers)
      return r.Fail(EParseError::BadCount, "finger count %lld out of [0, %d]", static_cast<long long>(nf),
                    Hand::kMaxFingers);
    h.right = lr == 1;
    h.num_fingers = static_cast<int>(nf);
    if (!r.Position(&h.position) || !r.Rotation(&h.rotation, h.tracked())) return false;
    for (int f = 0; f < h.num_fingers; ++f) {
      HandFinger& fi = h.fingers[f];
      if (!r.Position(&fi.position) || !r.Rotation(&fi.rotation, h.tracked())) return false;
      if (!r.Block(6, "finger parameters")) return false;
      double v[6];
      for (int i = 0; i < 6; ++i)
        if (!r.Num(i, &v[i], "finger parameter")) return false;
      fi.tip_radius = v[0];
      fi.phalanx_length[0] = v[1];
      fi.phalanx_angle[0] = v[2];
      fi.phalanx_length[1] = v[3];
      fi.phalanx_angle[1] = v[4];
      fi.phalanx_length[2] = v[5];
      // the tips are sent in the hand frame
      fi.room_position = h.position + h.rotation * fi.position;
      fi.room_rotation = h.rotation * fi.rotation;
    }
    out->push_back(h);
    if (DuplicateId(*out, h.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", h.id);
  }
  return true;
}

bool ParseHumans(LineReader& r, std::vector<Human>* humans, std::vector<HumanJoint>* joints, int* ncal) {
  int64_t cal = 0, n = 0;
  if (!r.HeaderInt(&cal, "calibrated count", 0, 1 << 24, EParseError::BadCount) || !r.Count(&n, "human count"))
    return false;
  *ncal = static_cast<int>(cal);
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    Human h;
    int64_t nj = 0;
    if (!r.Block(2, "id/joints") || !r.Id(0, &h.id) || !r.ToInt(r.tok[1], &nj, "joint count")) return false;
    if (nj < 0 || nj > Human::kMaxJoints)
      return r.Fail(EParseError::BadCount, "joint count %lld out of [0, %d]", static_cast<long long>(nj),
                    Human::kMaxJoints);
    h.first_joint = static_cast<int>(joints->size());
    h.num_joints = static_cast<int>(nj);
    for (int j = 0; j < h.num_joints; ++j) {
      HumanJoint jt;
      if (!r.Block(2, "joint id/quality") || !r.Id(0, &jt.id) || !r.Quality(1, &jt.quality)) return false;
      bool has_angles = false;
      if (!r.Position(&jt.position, jt.angles_deg.data(), 3, &has_angles)) return false;
      if (!r.Rotation(&jt.rotation, jt.quality >= 0.0)) return false;
      joints->push_back(jt);
    }
    humans->push_back(h);
    if (DuplicateId(*humans, h.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", h.id);
  }
  return true;
}

bool ParseInertials(LineReader& r, std::vector<InertialBody>* out) {
  int64_t n = 0;
  if (!r.Count(&n, "body count")) return false;
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    InertialBody b;
    int64_t st = 0;
    if (!r.Block(3, "id/state/drift") || !r.Id(0, &b.id) || !r.Int(1, &st, "state", 0, 3) ||
        !r.Num(2, &b.drift_deg, "drift"))
      return false;
    b.state = static_cast<int>(st);
    if (!r.Position(&b.position) || !r.Rotation(&b.rotation, b.tracked())) return false;
    out->push_back(b);
    if (DuplicateId(*out, b.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", b.id);
  }
  return true;
}

bool ParseMarkers(LineReader& r, std::vector<Marker>* out) {
  int64_t n = 0;
  if (!r.Count(&n, "marker count")) return false;
  for (int64_t k = 0; k < n; ++k) {
    r.object = static_cast<int>(k);
    Marker m;
    if (!r.Block(2, "id/quality") || !r.Id(0, &m.id) || !r.Quality(1, &m.quality)) return false;
    if (!r.Position(&m.position)) return false;
    out->push_back(m);
    if (DuplicateId(*out, m.id)) return r.Fail(EParseError::BadValue, "duplicate id %d", m.id);
  }
  return true;
}

bool ParseStatus(LineReader& r, SystemStatus* st) {
  int64_t ng = 0;
  if (!r.Count(&ng, "group count")) return false;
  auto ints = [&](int from, int count, int* out) {
    for (int i = 0; i < count; ++i) {
      int64_t v = 0;
      if (!r.Int(from + i, &v, "status value", -(int64_t{1} << 31), (int64_t{1} << 31) - 1)) return false;
      out[i] = static_cast<int>(v);
    }
    return true;
  };
  for (int64_t g = 0; g < ng; ++g) {
    r.object = static_cast<int>(g);
    if (!r.Block(2, "status group")) return false;
    int64_t type = 0;
    if (!r.Int(0, &type, "group type", 0, 1 << 30)) return false;
    if (type > 2) return true;  // later groups are not known: ignored, as the SDK does
    if (type == 0 || type == 1) {
      int64_t nv = 0;
      if (!r.Int(1, &nv, "value count", type == 0 ? 3 : 5, kMaxTokens)) return false;
      if (!r.Block(static_cast<int>(nv), type == 0 ? "general status" : "message status")) return false;
      int v[5];
      if (!ints(0, type == 0 ? 3 : 5, v)) return false;
      if (type == 0) {
        st->has_general = true;
        st->num_cameras = v[0];
        st->num_bodies = v[1];
        st->num_markers = v[2];
      } else {
        st->has_messages = true;
        st->camera_errors = v[0];
        st->camera_warnings = v[1];
        st->other_errors = v[2];
        st->other_warnings = v[3];
        st->info = v[4];
      }
    } else {
      if (r.ntok < 3) return r.Fail(EParseError::MissingBlock, "camera status header needs 3 numbers");
      int64_t ncam = 0, nv = 0;
      if (!r.Int(1, &ncam, "camera count", 0, 4096) || !r.Int(2, &nv, "value count", 3, kMaxTokens - 1)) return false;
      for (int64_t c = 0; c < ncam; ++c) {
        if (!r.Block(static_cast<int>(nv) + 1, "camera status")) return false;
        int v[4];
        if (!ints(0, 4, v)) return false;
        st->cameras.push_back({v[0], v[1], v[2], v[3]});
      }
    }
  }
  return true;
}

bool ParseLineType(std::string_view id, ELine* out) {
  for (int i = 0; i < static_cast<int>(ELine::Count); ++i)
    if (id == LineName(static_cast<ELine>(i))) {
      *out = static_cast<ELine>(i);
      return true;
    }
  return false;
}

}  // namespace

void DTrackParser::CountOversized(size_t size) {
  ++stats_.errors[static_cast<int>(EParseError::Oversized)];
  last_category_ = EParseError::Oversized;
  std::snprintf(last_error_, sizeof(last_error_), "datagram of %zu bytes exceeds the %zu-byte limit", size,
                options_.max_datagram_bytes);
}

int DTrackParser::Parse(const char* data, size_t size, DTrackFrame* out) {
  ++stats_.datagrams;
  out->Clear();
  if (size > options_.max_datagram_bytes) {
    CountOversized(size);
    return 1;
  }
  const char* end = size ? static_cast<const char*>(std::memchr(data, '\0', size)) : nullptr;
  if (!end) end = data + size;
  int errors = 0;
  int line_no = 0;
  const char* p = data;
  while (p < end) {
    if (*p == '\r' || *p == '\n') {
      ++p;
      continue;
    }
    const char* line_end = p;
    while (line_end < end && *line_end != '\r' && *line_end != '\n') ++line_end;
    ++line_no;
    ++stats_.lines;
    LineReader r;
    r.p = p;
    r.end = line_end;
    r.line_no = line_no;
    r.type = ELine::Count;
    r.rotation_tolerance = options_.rotation_tolerance;
    p = line_end;

    // identifier
    r.SkipSpace();
    const char* id_begin = r.p;
    while (r.p < r.end && !IsSpace(*r.p)) ++r.p;
    ELine type;
    if (!ParseLineType(std::string_view(id_begin, static_cast<size_t>(r.p - id_begin)), &type)) {
      ++stats_.unknown_lines;
      continue;
    }
    r.type = type;
    if (out->Has(type)) ++stats_.duplicate_lines;

    // each category is read into the scratch frame and swapped in when the whole line is good
    DTrackFrame& s = scratch_;
    bool ok = false;
    switch (type) {
      case ELine::Fr: {
        int64_t v = 0;
        ok = r.HeaderInt(&v, "frame counter", 0, UINT32_MAX, EParseError::BadValue);
        if (ok) s.frame = static_cast<uint32_t>(v);
        break;
      }
      case ELine::Ts: {
        double v = 0.0;
        ok = r.HeaderNumber(&v, "timestamp");
        if (ok && !(v >= 0.0 && v <= 86400.0))
          ok = r.Fail(EParseError::BadValue, "timestamp %g outside a day", v);
        if (ok) s.timestamp = v;
        break;
      }
      case ELine::Ts2: {
        int64_t sec = 0, usec = 0, lat = 0;
        ok = r.HeaderInt(&sec, "seconds", 0, INT64_MAX / 2, EParseError::BadValue) &&
             r.HeaderInt(&usec, "microseconds", 0, 999999, EParseError::BadValue) &&
             r.HeaderInt(&lat, "latency", 0, INT64_MAX / 2, EParseError::BadValue);
        if (ok) {
          s.ts2_sec = sec;
          s.ts2_usec = usec;
          s.latency_us = lat;
        }
        break;
      }
      case ELine::Cal6d:
      case ELine::CalGl: {
        int64_t v = 0;
        ok = r.HeaderInt(&v, "calibrated count", 0, 1 << 24, EParseError::BadCount);
        if (ok) (type == ELine::Cal6d ? s.cal_bodies : s.cal_hands) = static_cast<int>(v);
        break;
      }
      case ELine::Body6d:
        s.bodies.clear();
        ok = ParseBodies(r, &s.bodies, true);
        break;
      case ELine::Cov6d:
        s.covariances.clear();
        ok = ParseCovariances(r, &s.covariances);
        break;
      case ELine::Flystick1:
      case ELine::Flystick2:
        s.flysticks.clear();
        ok = type == ELine::Flystick1 ? ParseFlysticks1(r, &s.flysticks) : ParseFlysticks2(r, &s.flysticks, &s.cal_flysticks);
        break;
      case ELine::Tool1:
      case ELine::Tool2:
        s.tools.clear();
        ok = type == ELine::Tool1 ? ParseTools1(r, &s.tools) : ParseTools2(r, &s.tools, &s.cal_tools);
        break;
      case ELine::ToolRef:
        s.tool_refs.clear();
        ok = ParseToolRefs(r, &s.tool_refs, &s.cal_tool_refs);
        break;
      case ELine::Hand:
        s.hands.clear();
        ok = ParseHands(r, &s.hands);
        break;
      case ELine::Human:
        s.humans.clear();
        s.human_joints.clear();
        ok = ParseHumans(r, &s.humans, &s.human_joints, &s.cal_humans);
        break;
      case ELine::Inertial:
        s.inertials.clear();
        ok = ParseInertials(r, &s.inertials);
        break;
      case ELine::Marker:
        s.markers.clear();
        ok = ParseMarkers(r, &s.markers);
        break;
      case ELine::Status:
        s.status.cameras.clear();
        s.status.has_general = s.status.has_messages = false;
        ok = ParseStatus(r, &s.status);
        break;
      case ELine::Count:
        break;
    }
    if (!ok) {
      ++errors;
      ++stats_.errors[static_cast<int>(r.category)];
      last_category_ = r.category;
      if (r.object >= 0)
        std::snprintf(last_error_, sizeof(last_error_), "line %d (%s): object %d: %s", line_no, LineName(type),
                      r.object, r.message);
      else
        std::snprintf(last_error_, sizeof(last_error_), "line %d (%s): %s", line_no, LineName(type), r.message);
      // the line is dropped; an earlier good line of the same type stays
      continue;
    }
    if (r.Trailing()) ++stats_.trailing_data;
    ++stats_.lines_parsed;
    out->present |= 1u << static_cast<int>(type);
    switch (type) {
      case ELine::Fr: out->frame = s.frame; break;
      case ELine::Ts:
        if (!out->Has(ELine::Ts2)) out->timestamp = s.timestamp;
        break;
      case ELine::Ts2:
        out->ts2_sec = s.ts2_sec;
        out->ts2_usec = s.ts2_usec;
        out->latency_us = s.latency_us;
        out->timestamp = static_cast<double>(s.ts2_sec % 86400) + static_cast<double>(s.ts2_usec) * 1e-6;
        break;
      case ELine::Cal6d: out->cal_bodies = s.cal_bodies; break;
      case ELine::CalGl: out->cal_hands = s.cal_hands; break;
      case ELine::Body6d: std::swap(out->bodies, s.bodies); break;
      case ELine::Cov6d: std::swap(out->covariances, s.covariances); break;
      case ELine::Flystick1:
      case ELine::Flystick2:
        std::swap(out->flysticks, s.flysticks);
        out->cal_flysticks = type == ELine::Flystick2 ? s.cal_flysticks : static_cast<int>(out->flysticks.size());
        break;
      case ELine::Tool1:
      case ELine::Tool2:
        std::swap(out->tools, s.tools);
        out->cal_tools = type == ELine::Tool2 ? s.cal_tools : static_cast<int>(out->tools.size());
        break;
      case ELine::ToolRef:
        std::swap(out->tool_refs, s.tool_refs);
        out->cal_tool_refs = s.cal_tool_refs;
        break;
      case ELine::Hand: std::swap(out->hands, s.hands); break;
      case ELine::Human:
        std::swap(out->humans, s.humans);
        std::swap(out->human_joints, s.human_joints);
        out->cal_humans = s.cal_humans;
        break;
      case ELine::Inertial: std::swap(out->inertials, s.inertials); break;
      case ELine::Marker: std::swap(out->markers, s.markers); break;
      case ELine::Status: std::swap(out->status, s.status); break;
      case ELine::Count: break;
    }
  }
  return errors;
}

}  // namespace gs::tracking
