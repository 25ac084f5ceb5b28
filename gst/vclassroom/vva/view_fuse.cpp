#include <gst/vclassroom/vva/view_fuse.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

#include <gst/vclassroom/core/simd.h>

namespace vclassroom {

namespace {

struct ViewRow {
  const uint8_t* c;  // RGB
  const uint16_t* d;
  const uint8_t* l;  // a row of zeros for views without labels
  const uint8_t* w;
};

// Per-row accumulators, kept in L1 while the views are added one by one.
struct BlendScratch {
  std::vector<int> zmin, lab, r, g, b, z;
  std::vector<float> limit, weight, acc0, acc1, acc2, zsum, wsum, wbest;
  std::vector<uint8_t> zeros;
  void resize(int W) {
    for (auto* v : {&limit, &weight, &acc0, &acc1, &acc2, &zsum, &wsum, &wbest}) v->resize(size_t(W));
    for (auto* v : {&zmin, &lab, &r, &g, &b, &z}) v->resize(size_t(W));
    zeros.assign(size_t(W), 0);
  }
};

// A view's samples added to a row's accumulators; see blend_row. Separate
// functions with restrict parameters, so that the compiler knows the rows do
// not overlap and vectorises each loop.
//
// Every value is loaded whatever the selects decide and the label is picked
// with a mask: a load the compiler may only do on one side of a condition
// (the weight table, the label) keeps the loop from vectorising.
VCLASSROOM_SIMD_INLINE void add_view(int W, const uint8_t* __restrict p, const uint16_t* __restrict d,
                               const uint8_t* __restrict l, const float* __restrict wrow, const float* __restrict limit,
                               float* __restrict a0, float* __restrict a1, float* __restrict a2, float* __restrict zs,
                               float* __restrict ws, float* __restrict wb, int* __restrict lab) {
  for (int x = 0; x < W; ++x) {
    const int z = d[x];
    const float zf = float(z);
    const float wt = ((z != 0) & (zf <= limit[x])) ? wrow[x] : 0.f;
    a0[x] += wt * float(p[3 * x]);
    a1[x] += wt * float(p[3 * x + 1]);
    a2[x] += wt * float(p[3 * x + 2]);
    zs[x] += wt * zf;
    ws[x] += wt;
    const float wbx = wb[x];
    const int labx = lab[x], lx = l[x];
    const bool best = wt > wbx;
    wb[x] = best ? wt : wbx;
    lab[x] = labx ^ ((labx ^ lx) & -int(best));
  }
}

VCLASSROOM_SIMD_INLINE void weights_of(int W, const uint8_t* __restrict w, const float* __restrict wlut,
                                 float* __restrict wrow) {
  for (int x = 0; x < W; ++x) wrow[x] = wlut[w[x]];
}

VCLASSROOM_SIMD_INLINE void nearest_of(int W, const uint16_t* __restrict d, const uint8_t* __restrict w,
                                 int* __restrict zmin) {
  for (int x = 0; x < W; ++x) {
    const int z = d[x];
    zmin[x] = ((z != 0) & (w[x] != 0) & (z < zmin[x])) ? z : zmin[x];
  }
}

VCLASSROOM_SIMD_INLINE void start_row(int W, const int* __restrict zmin, float tol_mm, float tol_ratio,
                                float* __restrict limit, float* __restrict a0, float* __restrict a1,
                                float* __restrict a2, float* __restrict zs, float* __restrict ws, float* __restrict wb,
                                int* __restrict lab) {
  for (int x = 0; x < W; ++x) {
    const float zf = float(zmin[x]), rel = tol_ratio * zf;
    limit[x] = zf + (tol_mm < rel ? rel : tol_mm);
    a0[x] = 0.f;
    a1[x] = 0.f;
    a2[x] = 0.f;
    zs[x] = 0.f;
    ws[x] = 0.f;
    wb[x] = 0.f;  // every weight that counts is > 0
    lab[x] = 0;
  }
}

VCLASSROOM_SIMD_INLINE void finish_row(int W, const int* __restrict zmin, const float* __restrict a0,
                                 const float* __restrict a1, const float* __restrict a2, const float* __restrict zs,
                                 const float* __restrict ws, int* __restrict r, int* __restrict g, int* __restrict b,
                                 int* __restrict z) {
  for (int x = 0; x < W; ++x) {
    const bool seen = zmin[x] != 65536;
    const float iw = 1.0f / (ws[x] + (seen ? 0.f : 1.f));  // no weight where nothing is seen
    const int keep = -int(seen);
    r[x] = int(a0[x] * iw + 0.5f) & keep;
    g[x] = int(a1[x] * iw + 0.5f) & keep;
    b[x] = int(a2[x] * iw + 0.5f) & keep;
    z[x] = int(zs[x] * iw + 0.5f) & keep;
  }
}

// Narrowing and interleaving on their own: next to the float work above the
// compiler does not vectorise them.
VCLASSROOM_SIMD_INLINE void store_row(int W, const int* __restrict r, const int* __restrict g, const int* __restrict b,
                                const int* __restrict z, const int* __restrict lab, uint8_t* __restrict oc,
                                uint16_t* __restrict od, uint8_t* __restrict ol) {
  for (int x = 0; x < W; ++x) {
    oc[3 * x] = uint8_t(r[x]);
    oc[3 * x + 1] = uint8_t(g[x]);
    oc[3 * x + 2] = uint8_t(b[x]);
    od[x] = uint16_t(z[x]);
    ol[x] = uint8_t(lab[x]);  // 0 where nothing is seen: no view was best there
  }
}

// FuseParams::first_is_base: rows[0] is the room, which lies behind the learners everywhere (it is the empty
// room's), so where a learner stands within the tolerance of the room (on a chair, against a desk or the
// wall) the room's colour would blend into the learner's: there the room only hides what lies behind it, and
// the learners' and the other samples within the tolerance make the colour.
VCLASSROOM_SIMD_INLINE void learner_within(int W, const uint16_t* __restrict d, const uint8_t* __restrict w,
                                     const uint8_t* __restrict l, const float* __restrict limit,
                                     float* __restrict base_weight) {
  for (int x = 0; x < W; ++x)
    base_weight[x] = (l[x] != 0) & (d[x] != 0) & (w[x] != 0) & (float(d[x]) <= limit[x]) ? 0.0f : base_weight[x];
}

// One output row: the nearest sample's z-buffer test, then every view's
// sample within the tolerance blended by weight. The views are added in the
// same order and with the same float operations per pixel as a loop over the
// views of each pixel would (a view that does not count adds exactly 0), so
// the result does not depend on the vector width. `wlut` holds each weight
// code's blending weight, 0 for code 0 (no sample). `over_base`: rows[0] is the
// room (learner_within), added last, once the others' samples are known.
VCLASSROOM_SIMD_CLONES
void blend_row(int W, int k, const ViewRow* rows, const float* wlut, float tol_mm, float tol_ratio, BlendScratch& s,
               uint8_t* oc, uint16_t* od, uint8_t* ol, bool over_base = false) {
  int* zmin = s.zmin.data();
  for (int x = 0; x < W; ++x) zmin[x] = 65536;
  for (int c = 0; c < k; ++c) nearest_of(W, rows[c].d, rows[c].w, zmin);
  start_row(W, zmin, tol_mm, tol_ratio, s.limit.data(), s.acc0.data(), s.acc1.data(), s.acc2.data(), s.zsum.data(),
            s.wsum.data(), s.wbest.data(), s.lab.data());
  for (int i = 0; i < k; ++i) {
    const int c = over_base ? k - 1 - i : i;
    weights_of(W, rows[c].w, wlut, s.weight.data());
    if (over_base && c == 0)
      for (int o = 1; o < k; ++o) learner_within(W, rows[o].d, rows[o].w, rows[o].l, s.limit.data(), s.weight.data());
    add_view(W, rows[c].c, rows[c].d, rows[c].l, s.weight.data(), s.limit.data(), s.acc0.data(), s.acc1.data(),
             s.acc2.data(), s.zsum.data(), s.wsum.data(), s.wbest.data(), s.lab.data());
  }
  finish_row(W, zmin, s.acc0.data(), s.acc1.data(), s.acc2.data(), s.zsum.data(), s.wsum.data(), s.r.data(), s.g.data(),
             s.b.data(), s.z.data());
  store_row(W, s.r.data(), s.g.data(), s.b.data(), s.z.data(), s.lab.data(), oc, od, ol);
}

// The fade of the fill towards a neutral grey with the distance to the nearest seen pixel: untouched up to
// `start` px, grey from `start + length` px on.
//
// The distance is OpenCV's 3x3 chamfer (steps of kStraight and kDiagonal px),
// and it is taken only where it can matter, with the very values the whole
// frame's transform gives there: a pixel farther than `start` from everything
// seen lies in a block of unseen pixels (kBlock px square: a seen pixel in
// its block would be at most (kBlock - 1) * kDiagonal away), so only the boxes
// around those blocks are faded; and the transform runs on each box grown by
// the farthest distance asked for, so every seen pixel nearer than that
// to a pixel of the box is inside it (a chamfer path stays within the box of its
// ends). The blocks are taken in parts, rows of blocks joined while their grown
// boxes meet: a view whose unseen blocks lie along its top and in a corner (a
// lecturer who looks a little up, off to one side) transforms two bands, not the
// whole frame. A view with no such block skips the transform (a full-frame pass of
// a few ms).
constexpr double kStraight = 0.955, kDiagonal = 1.3693;  // cv::distanceTransform's DIST_L2 3x3 mask

struct UnseenPart {
  cv::Rect blocks;  // where a pixel may be farther than the fade's start
  cv::Rect around;  // the transform's box
  cv::Mat distance;  // CV_32FC1 over `around`
};
using UnseenDistance = std::vector<UnseenPart>;

// The transform of part `i` (its blocks set), exact up to `margin` px less one straight step.
void measure_part(const cv::Mat& depth, int margin, size_t i, UnseenPart* part) {
  part->around = cv::Rect(part->blocks.x - margin, part->blocks.y - margin, part->blocks.width + 2 * margin,
                          part->blocks.height + 2 * margin) &
                 cv::Rect(0, 0, depth.cols, depth.rows);
  // Kept between frames, a distance image per part (a fresh image each frame costs page faults); the part's
  // `distance` shares it.
  static thread_local cv::Mat holes;
  static thread_local std::vector<cv::Mat> distances;
  if (distances.size() <= i) distances.resize(i + 1);
  cv::compare(depth(part->around), 0, holes, cv::CMP_EQ);
  cv::distanceTransform(holes, distances[i], cv::DIST_L2, cv::DIST_MASK_3);
  part->distance = distances[i];
}

// The distances of UnseenDistance, exact up to `exact_to` px; false when no pixel is farther than `start`.
bool measure_unseen(const cv::Mat& depth, double start, double exact_to, UnseenDistance* u) {
  constexpr int kBlock = 8;
  const int W = depth.cols, H = depth.rows;
  const int margin = int(std::ceil(exact_to / kStraight)) + 1;
  u->clear();
  if (start < (kBlock - 1) * kDiagonal) {
    u->push_back(UnseenPart{cv::Rect(0, 0, W, H), {}, {}});
    measure_part(depth, margin, 0, &u->back());
    return true;
  }
  std::vector<uint8_t> all_unseen(size_t((W + kBlock - 1) / kBlock));
  cv::Rect part;  // the blocks of the part being gathered
  for (int by = 0; by < H; by += kBlock) {
    std::fill(all_unseen.begin(), all_unseen.end(), 1);
    for (int y = by; y < std::min(H, by + kBlock); ++y) {
      const uint16_t* d = depth.ptr<uint16_t>(y);
      for (size_t b = 0; b < all_unseen.size(); ++b) {
        if (!all_unseen[b]) continue;  // most blocks: settled by their first row
        const int x_end = std::min(W, int(b + 1) * kBlock);
        for (int x = int(b) * kBlock; x < x_end; ++x)
          if (d[x]) {
            all_unseen[b] = 0;
            break;
          }
      }
    }
    int x0 = W, x1 = 0;
    for (size_t b = 0; b < all_unseen.size(); ++b) {
      if (!all_unseen[b]) continue;
      x0 = std::min(x0, int(b) * kBlock);
      x1 = std::max(x1, std::min(W, int(b + 1) * kBlock));
    }
    if (x0 >= x1) continue;
    const cv::Rect row(x0, by, x1 - x0, std::min(H, by + kBlock) - by);
    // Joined to the part when their boxes grown by the margin meet (their transforms would overlap).
    const bool joins = part.area() > 0 && row.y - (part.y + part.height) < 2 * margin &&
                       row.x < part.x + part.width + 2 * margin && part.x < row.x + row.width + 2 * margin;
    if (joins) {
      part |= row;
      continue;
    }
    if (part.area() > 0) u->push_back(UnseenPart{part, {}, {}});
    part = row;
  }
  if (part.area() > 0) u->push_back(UnseenPart{part, {}, {}});
  for (size_t i = 0; i < u->size(); ++i) measure_part(depth, margin, i, &(*u)[i]);
  return !u->empty();
}

// The holes farther than `beyond` from everything seen, set in `left` (zero elsewhere); how many.
int mark_far_holes(const UnseenDistance& u, double beyond, cv::Mat& left) {
  left = cv::Scalar::all(0);  // by memset (setTo copies a pattern)
  const float limit = float(beyond);
  int count = 0;
  for (const UnseenPart& p : u)
    for (int y = p.blocks.y; y < p.blocks.y + p.blocks.height; ++y) {
      const float* d = p.distance.ptr<float>(y - p.around.y) - p.around.x;
      uint8_t* l = left.ptr<uint8_t>(y);
      for (int x = p.blocks.x; x < p.blocks.x + p.blocks.width; ++x) {
        const bool is_far = d[x] > limit;
        l[x] = is_far ? 255 : 0;
        count += is_far;
      }
    }
  return count;
}

// The fade itself. The pixels in `left` (optional: the fill left them to the fade, all of them grey here) are
// marked in `filled` as made.
void fade_unseen(const UnseenDistance& u, cv::Mat& color, double start, double length, const cv::Mat* left,
                 cv::Mat& filled) {
  constexpr float kNeutral = 96.0f;  // a dim grey, calm beside any picture
  const float s = float(start), inv_len = 1.0f / float(std::max(length, 1.0));
  for (const UnseenPart& p : u)
    for (int y = p.blocks.y; y < p.blocks.y + p.blocks.height; ++y) {
      const float* d = p.distance.ptr<float>(y - p.around.y) - p.around.x;
      uint8_t* c = color.ptr<uint8_t>(y);
      for (int x = p.blocks.x; x < p.blocks.x + p.blocks.width; ++x) {
        if (d[x] <= s) continue;
        float a = std::min(1.0f, (d[x] - s) * inv_len);
        a = a * a * (3 - 2 * a);  // smoothstep: no visible ring where the fade starts
        for (int k = 0; k < 3; ++k) c[3 * x + k] = uint8_t(float(c[3 * x + k]) * (1 - a) + kNeutral * a + 0.5f);
      }
      if (left) {
        const uint8_t* l = left->ptr<uint8_t>(y);
        uint8_t* f = filled.ptr<uint8_t>(y);
        for (int x = p.blocks.x; x < p.blocks.x + p.blocks.width; ++x) f[x] |= l[x];
      }
    }
}

// first_is_base: `bit` where the row `d` has a sample.
VCLASSROOM_SIMD_CLONES
void mark_samples(int n, const uint16_t* d, uint8_t bit, uint8_t* marks) {
  for (int i = 0; i < n; ++i) marks[i] |= d[i] != 0 ? bit : uint8_t(0);
}

// The end of the run of marks in marks[x..n) that starts at x, unmarked ones (`marked` false: 0) or marked ones
// (not 0), 8 marks at a time where it can.
int run_end(const uint8_t* marks, int x, int n, bool marked) {
  constexpr uint64_t kOnes = 0x0101010101010101ull, kHighs = 0x8080808080808080ull;
  while (x + 8 <= n) {
    uint64_t eight;
    std::memcpy(&eight, marks + x, 8);
    const bool has_zero = ((eight - kOnes) & ~eight & kHighs) != 0;  // some byte is 0
    if (marked ? has_zero : eight != 0) break;
    x += 8;
  }
  while (x < n && (marks[x] != 0) == marked) ++x;
  return x;
}

// FuseParams::first_is_base, one output row: the base (rows[0]) copied where no other view has a sample
// (depth 0 where it has none, as the blend gives), blend_row over it over the column spans where one has.
// A view with tiles (`tiled`: they fit the view) has its samples only there. `others`, `span_rows`: scratch.
void fuse_row_over_base(int W, int y, const std::vector<const WarpedView*>& views, const std::vector<bool>& tiled,
                        const ViewRow* rows, const float* wlut, float tol_mm, float tol_ratio, BlendScratch& scratch,
                        std::vector<uint8_t>* others, std::vector<ViewRow>* span_rows, uint8_t* oc, uint16_t* od,
                        uint8_t* ol) {
  const int k = int(views.size());
  others->assign(size_t(W), 0);
  uint8_t* const marks = others->data();
  // View c's mark: bit c (views past the eighth share the last bit, and a span with it blends them all).
  auto bit_of = [](int c) { return uint8_t(1u << std::min(c, 7)); };
  for (int c = 1; c < k; ++c) {
    const SampleTiles& tiles = views[size_t(c)]->tiles;
    if (!tiled[size_t(c)]) {
      mark_samples(W, rows[c].d, bit_of(c), marks);
      continue;
    }
    const auto [first, end] = tiles.of_row(y);
    for (int32_t i = first; i < end; ++i) {
      const auto [x0, x1] = tiles.spans[size_t(i)];
      mark_samples(x1 - x0, rows[c].d + x0, bit_of(c), marks + x0);
    }
  }
  for (int x = 0; x < W;) {
    if (!marks[x]) {
      const int e = run_end(marks, x, W, false);
      // A plane the base was rendered into (share_room_planes) holds it there already.
      if (rows[0].c != oc) std::memcpy(oc + 3 * x, rows[0].c + 3 * x, size_t(e - x) * 3);
      if (rows[0].d != od) std::memcpy(od + x, rows[0].d + x, size_t(e - x) * 2);
      if (rows[0].l != ol) std::memcpy(ol + x, rows[0].l + x, size_t(e - x));
      x = e;
      continue;
    }
    // Gaps of up to kJoinPx between spans are blended with them, and a span is rounded up to whole vectors: the
    // blend of a few pixels is mostly its loops' scalar remainders (a view's learners give a thousand spans of
    // about 30 px), and where the base alone has a sample its blend is the base to the grey level (its colour x
    // weight / weight rounds back to it; FuseParams::first_is_base: no sample where its weight is 0).
    constexpr int kJoinPx = 16, kRoundPx = 16;
    int e = run_end(marks, x, W, true);
    for (int gap_end = run_end(marks, e, W, false); gap_end < W && gap_end - e <= kJoinPx;
         gap_end = run_end(marks, e, W, false))
      e = run_end(marks, gap_end, W, true);
    e = std::min(W, x + (e - x + kRoundPx - 1) / kRoundPx * kRoundPx);
    // The views with a sample in the span, the base first: one without adds exactly 0 to every sum (and is
    // nearest nowhere), so leaving it out gives the same blend.
    uint8_t present = 0;
    for (int i = x; i < e; ++i) present |= marks[i];
    int blended = 0;
    for (int c = 0; c < k; ++c)
      if (c == 0 || (present & bit_of(c)))
        (*span_rows)[size_t(blended++)] = ViewRow{rows[c].c + 3 * x, rows[c].d + x, rows[c].l + x, rows[c].w + x};
    blend_row(e - x, blended, span_rows->data(), wlut, tol_mm, tol_ratio, scratch, oc + 3 * x, od + x, ol + x,
              true);
    x = e;
  }
}

}  // namespace

void fuse_views(const std::vector<const WarpedView*>& views_in, const FuseParams& prm, FusedView* out,
                HoleFillHistory* fill_history) {
  std::vector<const WarpedView*> views;
  for (const WarpedView* v : views_in)
    if (v && !v->color.empty()) views.push_back(v);
  CV_Assert(!views.empty());
  const cv::Size size = views[0]->color.size();
  for (const WarpedView* v : views) CV_Assert(v->color.size() == size && v->depth.size() == size);
  out->color.create(size, CV_8UC3);
  out->depth.create(size, CV_16UC1);
  out->label.create(size, CV_8UC1);
  const int k = int(views.size());
  float wlut[256];
  wlut[0] = 0;  // no sample
  for (int i = 1; i < 256; ++i) wlut[i] = float(std::pow(i / 255.0, prm.weight_power)) + 1e-6f;
  const float tol_ratio = float(prm.depth_tol_ratio), tol_mm = float(prm.depth_tol_mm);
  static thread_local BlendScratch scratch;
  scratch.resize(size.width);
  std::vector<ViewRow> rows(views.size());
  std::vector<uint8_t> others;  // first_is_base: per column, whether another view has a sample
  std::vector<ViewRow> span_rows(views.size());
  std::vector<bool> tiled(views.size());
  for (size_t c = 0; c < views.size(); ++c)
    tiled[c] = !views[c]->tiles.anywhere() && views[c]->tiles.fit(size.width, size.height);
  for (int y = 0; y < size.height; ++y) {
    for (int c = 0; c < k; ++c)
      rows[c] = ViewRow{views[c]->color.ptr<uint8_t>(y), views[c]->depth.ptr<uint16_t>(y),
                        views[c]->label.empty() ? scratch.zeros.data() : views[c]->label.ptr<uint8_t>(y),
                        views[c]->weight.ptr<uint8_t>(y)};
    if (!prm.first_is_base || k < 2) {
      blend_row(size.width, k, rows.data(), wlut, tol_mm, tol_ratio, scratch, out->color.ptr<uint8_t>(y),
                out->depth.ptr<uint16_t>(y), out->label.ptr<uint8_t>(y));
      continue;
    }
    fuse_row_over_base(size.width, y, views, tiled, rows.data(), wlut, tol_mm, tol_ratio, scratch, &others, &span_rows,
                       out->color.ptr<uint8_t>(y), out->depth.ptr<uint16_t>(y), out->label.ptr<uint8_t>(y));
  }
  // Reused like the other planes: a fresh 0.5 MB each frame costs page faults.
  out->filled.create(size, CV_8UC1);
  out->filled = cv::Scalar::all(0);
  // The fused depth stays as seen (0 in the holes): the fill's depth is a guess.
  const int unseen = int(out->depth.total()) - cv::countNonZero(out->depth);
  out->unseen_share = double(unseen) / double(out->depth.total());
  if (!prm.fill_holes) return;
  const HoleFillParams fill = hole_fill_params(prm);
  const double start = prm.fade_start * size.width, length = prm.fade_length * size.width;
  // The holes farther than this from anything seen are grey after the fade, whatever the fill made there, and
  // so is every pixel whose fill reads theirs (within hole_fill_reach, at most that many diagonal steps nearer):
  // the fill leaves them to the fade. A lecturer looking where no camera does is half holes, most of them
  // there. (The pyramid only: the rays' fill, kept for comparison, fills them all.)
  const double far = start + length + hole_fill_reach(fill) * kDiagonal + 1;
  UnseenDistance unseen_distance;
  const bool fade = prm.fade_unseen && unseen > 0 && measure_unseen(out->depth, start, far, &unseen_distance);
  static thread_local cv::Mat left;
  const bool leave = fade && fill.method == HoleFillMethod::Pyramid;
  int left_count = 0;
  if (leave) {
    left.create(size, CV_8UC1);
    left_count = mark_far_holes(unseen_distance, far, left);
  }
  fill_holes(out->color, out->depth, fill, out->filled, nullptr, fill_history, leave ? &left : nullptr);
  // The holes left to the fade count as made where the fill would have made them: the pyramid fills every hole
  // or, with too little seen to hold a value (nothing, or a few pixels), none; the holes it did fill say which.
  const bool made =
      leave && unseen < int(out->depth.total()) && (left_count == unseen || cv::countNonZero(out->filled) > 0);
  if (fade) fade_unseen(unseen_distance, out->color, start, length, made ? &left : nullptr, out->filled);
}

void share_room_planes(cv::Size size, FusedView* fused, WarpedView* room) {
  fused->color.create(size, CV_8UC3);
  fused->depth.create(size, CV_16UC1);
  fused->label.create(size, CV_8UC1);
  room->color = fused->color;
  room->depth = fused->depth;
  room->label = fused->label;
}

void fill_holes_from_background(cv::Mat& color, cv::Mat& depth, double background_ratio, int smooth_px,
                                cv::Mat* filled, double texture) {
  CV_Assert(color.type() == CV_8UC3 && depth.type() == CV_16UC1 && color.size() == depth.size());
  cv::Mat mask = cv::Mat::zeros(color.size(), CV_8UC1);
  if (filled) *filled = mask;  // shares the data
  // The filled depth goes to a new buffer, as before: whoever shares the
  // caller's depth keeps the unfilled one.
  cv::Mat new_depth = depth.clone();
  HoleFillParams p;
  p.method = HoleFillMethod::Rays;
  p.background_ratio = background_ratio;
  p.smooth_px = smooth_px;
  p.texture = texture;
  fill_holes(color, depth, p, mask, &new_depth);
  depth = new_depth;
}

bool same_rendered_view(const WarpedPose& a, const WarpedPose& b) {
  const RenderedPose &p = a.rendered, &q = b.rendered;
  if (!a.known || !b.known || !p.known || !q.known) return false;
  return std::equal(p.position, p.position + 3, q.position) &&
         std::equal(p.orientation, p.orientation + 4, q.orientation);
}

HoleFillParams hole_fill_params(const FuseParams& fuse) {
  HoleFillParams p;
  p.method = fuse.fill_method;
  p.background_ratio = fuse.background_ratio;
  p.smooth_px = fuse.fill_smooth_px;
  p.texture = fuse.fill_texture;
  return p;
}

std::vector<bool> stale_poses(const std::vector<WarpedPose>& inputs, int64_t window_ns,
                              std::optional<uint64_t> steering_session) {
  std::vector<bool> stale(inputs.size(), false);
  const bool any_known = std::any_of(inputs.begin(), inputs.end(), [](const WarpedPose& p) { return p.known; });
  if (!any_known) return stale;
  for (size_t i = 0; i < inputs.size(); ++i) {
    const WarpedPose& p = inputs[i];
    if (!p.known || (steering_session && p.session != *steering_session)) {
      stale[i] = true;
      continue;
    }
    // The newest pose of its own session.
    const WarpedPose* newest = &p;
    for (const WarpedPose& q : inputs)
      if (q.known && q.session == p.session && q.seq > newest->seq) newest = &q;
    if (newest != &p) {
      const bool timed = p.viewer_time_ns >= 0 && newest->viewer_time_ns >= 0;
      stale[i] = !timed || newest->viewer_time_ns - p.viewer_time_ns > window_ns;
    }
  }
  return stale;
}

}  // namespace vclassroom
