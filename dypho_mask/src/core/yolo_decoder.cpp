#include "dypho/mask/yolo_decoder.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

namespace dypho {
namespace mask {
namespace {

std::string shapeString(const cv::Mat& m) {
  std::string s;
  for (int i = 0; i < m.dims; ++i) s += (i ? "x" : "") + std::to_string(m.size[i]);
  return s.empty() ? "empty" : s;
}

int yoloxCells(const cv::Size& input) {
  int n = 0;
  for (int s : {8, 16, 32}) n += (input.width / s) * (input.height / s);
  return n;
}

/// 2-D view rows x cols of a 3-D 1 x rows x cols tensor (no copy).
cv::Mat view2d(const cv::Mat& m) { return cv::Mat(m.size[1], m.size[2], CV_32F, const_cast<uchar*>(m.ptr())); }

bool keep(const std::vector<bool>& keep_class, int c) {
  return keep_class.empty() || (c >= 0 && c < static_cast<int>(keep_class.size()) && keep_class[c]);
}

cv::Rect2f clipBox(float cx, float cy, float w, float h, const cv::Size& input) {
  const float x0 = std::clamp(cx - 0.5f * w, 0.f, static_cast<float>(input.width));
  const float y0 = std::clamp(cy - 0.5f * h, 0.f, static_cast<float>(input.height));
  const float x1 = std::clamp(cx + 0.5f * w, 0.f, static_cast<float>(input.width));
  const float y1 = std::clamp(cy + 0.5f * h, 0.f, static_cast<float>(input.height));
  return {x0, y0, x1 - x0, y1 - y0};
}

std::vector<YoloDetection> classWiseNms(std::vector<YoloDetection> candidates, float score_threshold, float nms_iou) {
  std::map<int, std::vector<int>> by_class;
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) by_class[candidates[i].class_id].push_back(i);
  std::vector<YoloDetection> out;
  for (const auto& [cls, idx] : by_class) {
    (void)cls;
    std::vector<cv::Rect> boxes;
    std::vector<float> scores;
    for (int i : idx) {
      const cv::Rect2f& b = candidates[i].box_input;
      // NMSBoxes on integer rects: scale by 16 to keep sub-pixel precision.
      boxes.emplace_back(cv::Rect(cv::Point(cvRound(b.x * 16), cvRound(b.y * 16)),
                                  cv::Point(cvRound((b.x + b.width) * 16), cvRound((b.y + b.height) * 16))));
      scores.push_back(candidates[i].score);
    }
    std::vector<int> kept;
    cv::dnn::NMSBoxes(boxes, scores, score_threshold, nms_iou, kept);
    for (int k : kept) out.push_back(std::move(candidates[idx[k]]));
  }
  std::sort(out.begin(), out.end(), [](const YoloDetection& a, const YoloDetection& b) { return a.score > b.score; });
  return out;
}

}  // namespace

Letterbox makeLetterbox(const cv::Size& image_size, const cv::Size& input_size) {
  if (image_size.empty() || input_size.empty()) {
    throw std::invalid_argument("makeLetterbox: empty image or input size");
  }
  Letterbox lb;
  lb.image_size = image_size;
  lb.input_size = input_size;
  lb.scale = std::min(static_cast<double>(input_size.width) / image_size.width,
                      static_cast<double>(input_size.height) / image_size.height);
  const int w = static_cast<int>(std::lround(image_size.width * lb.scale));
  const int h = static_cast<int>(std::lround(image_size.height * lb.scale));
  lb.pad_x = std::floor((input_size.width - w) / 2.0);
  lb.pad_y = std::floor((input_size.height - h) / 2.0);
  return lb;
}

void letterboxImage(const cv::Mat& bgr, const Letterbox& lb, cv::Mat& input) {
  CV_Assert(bgr.type() == CV_8UC3 && bgr.size() == lb.image_size);
  input.create(lb.input_size, CV_8UC3);
  input.setTo(cv::Scalar(114, 114, 114));
  const int w = static_cast<int>(std::lround(lb.image_size.width * lb.scale));
  const int h = static_cast<int>(std::lround(lb.image_size.height * lb.scale));
  cv::Mat roi = input(cv::Rect(static_cast<int>(lb.pad_x), static_cast<int>(lb.pad_y), w, h));
  cv::resize(bgr, roi, roi.size(), 0, 0, cv::INTER_LINEAR);
}

YoloLayout parseYoloLayout(const std::string& name) {
  if (name == "auto") return YoloLayout::kAuto;
  if (name == "yolox") return YoloLayout::kYolox;
  if (name == "yolov8") return YoloLayout::kYolov8;
  if (name == "yolov8_seg") return YoloLayout::kYolov8Seg;
  if (name == "yolov5_seg") return YoloLayout::kYolov5Seg;
  throw std::invalid_argument("unknown YOLO layout '" + name +
                              "' (valid: auto, yolox, yolov8, yolov8_seg, yolov5_seg)");
}

std::string yoloLayoutName(YoloLayout layout) {
  switch (layout) {
    case YoloLayout::kAuto:
      return "auto";
    case YoloLayout::kYolox:
      return "yolox";
    case YoloLayout::kYolov8:
      return "yolov8";
    case YoloLayout::kYolov8Seg:
      return "yolov8_seg";
    case YoloLayout::kYolov5Seg:
      return "yolov5_seg";
  }
  return "?";
}

LayoutInfo inspectYoloOutputs(const std::vector<cv::Mat>& outputs, const cv::Size& input_size, YoloLayout requested) {
  LayoutInfo info;
  std::string shapes;
  for (const cv::Mat& m : outputs) shapes += (shapes.empty() ? "" : ", ") + shapeString(m);
  auto fail = [&](const std::string& why) {
    info.ok = false;
    info.message = "YOLO outputs [" + shapes + "] for input " + std::to_string(input_size.width) + "x" +
                   std::to_string(input_size.height) + ": " + why;
    return info;
  };
  if (outputs.empty() || outputs.size() > 2) return fail("expected 1 (detector) or 2 (seg) outputs");
  const cv::Mat& o = outputs[0];
  if (o.dims != 3 || o.size[0] != 1 || o.type() != CV_32F) return fail("output0 must be 1xAxB float");
  const int a = o.size[1], b = o.size[2];
  YoloLayout layout = requested;
  if (layout == YoloLayout::kAuto) {
    if (outputs.size() == 2) {
      layout = a < b ? YoloLayout::kYolov8Seg : YoloLayout::kYolov5Seg;
    } else if (a == yoloxCells(input_size)) {
      layout = YoloLayout::kYolox;
    } else if (a < b) {
      layout = YoloLayout::kYolov8;
    } else {
      return fail("cannot infer the layout (not YOLOX: " + std::to_string(yoloxCells(input_size)) +
                  " grid cells expected; not YOLOv8: channels-first 1xCxN with C < N expected); "
                  "set yolo_layout");
    }
  }
  info.layout = layout;
  const bool seg = layout == YoloLayout::kYolov8Seg || layout == YoloLayout::kYolov5Seg;
  if (seg != (outputs.size() == 2)) {
    return fail("layout " + yoloLayoutName(layout) + " needs " + (seg ? "2 outputs" : "1 output"));
  }
  if (seg) {
    const cv::Mat& p = outputs[1];
    if (p.dims != 4 || p.size[0] != 1 || p.type() != CV_32F) return fail("prototypes must be 1 x nm x mh x mw float");
    info.num_mask_coeffs = p.size[1];
  }
  switch (layout) {
    case YoloLayout::kYolox:
      if (a != yoloxCells(input_size))
        return fail("YOLOX needs " + std::to_string(yoloxCells(input_size)) + " rows (check yolo_input_size)");
      info.num_classes = b - 5;
      break;
    case YoloLayout::kYolov8:
      info.num_classes = a - 4;
      break;
    case YoloLayout::kYolov8Seg:
      info.num_classes = a - 4 - info.num_mask_coeffs;
      break;
    case YoloLayout::kYolov5Seg:
      info.num_classes = b - 5 - info.num_mask_coeffs;
      break;
    case YoloLayout::kAuto:
      break;
  }
  if (info.num_classes < 1) return fail("no class channels left for layout " + yoloLayoutName(layout));
  info.ok = true;
  return info;
}

std::vector<YoloDetection> decodeYoloOutputs(const std::vector<cv::Mat>& outputs, const LayoutInfo& info,
                                             const cv::Size& input_size, const std::vector<bool>& keep_class,
                                             float score_threshold, float nms_iou) {
  std::vector<YoloDetection> candidates;
  if (!info.ok) return candidates;
  const cv::Mat o = view2d(outputs[0]);
  const int nc = info.num_classes, nm = info.num_mask_coeffs;
  if (info.layout == YoloLayout::kYolox || info.layout == YoloLayout::kYolov5Seg) {
    // Rows are candidates.
    int row = 0;
    const bool yolox = info.layout == YoloLayout::kYolox;
    std::vector<std::pair<int, int>> grid;  // (stride, cells per row) per row for YOLOX
    for (int s : {8, 16, 32}) {
      if (!yolox) break;
      const int gw = input_size.width / s, gh = input_size.height / s;
      for (int i = 0; i < gw * gh; ++i) grid.emplace_back(s, gw);
    }
    std::vector<int> offset;  // index within its stride level
    int level_start = 0;
    for (size_t i = 0; i < grid.size(); ++i) {
      if (i > 0 && grid[i].first != grid[i - 1].first) level_start = static_cast<int>(i);
      offset.push_back(static_cast<int>(i) - level_start);
    }
    for (row = 0; row < o.rows; ++row) {
      const float* r = o.ptr<float>(row);
      const float obj = r[4];
      if (obj < score_threshold) continue;
      int best = 0;
      for (int c = 1; c < nc; ++c)
        if (r[5 + c] > r[5 + best]) best = c;
      const float score = obj * r[5 + best];
      if (score < score_threshold || !keep(keep_class, best)) continue;
      float cx = r[0], cy = r[1], w = r[2], h = r[3];
      if (yolox) {
        const int s = grid[row].first, gw = grid[row].second;
        const int gx = offset[row] % gw, gy = offset[row] / gw;
        cx = (cx + gx) * s;
        cy = (cy + gy) * s;
        w = std::exp(std::min(w, 10.f)) * s;
        h = std::exp(std::min(h, 10.f)) * s;
      }
      YoloDetection d;
      d.box_input = clipBox(cx, cy, w, h, input_size);
      d.class_id = best;
      d.score = score;
      if (nm > 0) d.coeffs.assign(r + 5 + nc, r + 5 + nc + nm);
      if (d.box_input.area() > 0.f) candidates.push_back(std::move(d));
    }
  } else {
    // Columns are candidates (channels-first).
    const int n = o.cols;
    for (int i = 0; i < n; ++i) {
      int best = 0;
      float best_score = o.at<float>(4, i);
      for (int c = 1; c < nc; ++c) {
        const float v = o.at<float>(4 + c, i);
        if (v > best_score) {
          best_score = v;
          best = c;
        }
      }
      if (best_score < score_threshold || !keep(keep_class, best)) continue;
      YoloDetection d;
      d.box_input = clipBox(o.at<float>(0, i), o.at<float>(1, i), o.at<float>(2, i), o.at<float>(3, i), input_size);
      d.class_id = best;
      d.score = best_score;
      for (int k = 0; k < nm; ++k) d.coeffs.push_back(o.at<float>(4 + nc + k, i));
      if (d.box_input.area() > 0.f) candidates.push_back(std::move(d));
    }
  }
  return classWiseNms(std::move(candidates), score_threshold, nms_iou);
}

cv::Rect boxInImage(const YoloDetection& d, const Letterbox& lb) {
  const cv::Point2d p0 = lb.toImage({d.box_input.x, d.box_input.y});
  const cv::Point2d p1 = lb.toImage({d.box_input.x + d.box_input.width, d.box_input.y + d.box_input.height});
  const cv::Rect r(cv::Point(static_cast<int>(std::floor(p0.x)), static_cast<int>(std::floor(p0.y))),
                   cv::Point(static_cast<int>(std::ceil(p1.x)), static_cast<int>(std::ceil(p1.y))));
  return r & cv::Rect(cv::Point(0, 0), lb.image_size);
}

void paintInstanceMask(const YoloDetection& d, const cv::Mat& protos, const Letterbox& lb, cv::Mat& mask_image) {
  CV_Assert(protos.dims == 4 && mask_image.type() == CV_8UC1 && mask_image.size() == lb.image_size);
  const int nm = protos.size[1], mh = protos.size[2], mw = protos.size[3];
  if (static_cast<int>(d.coeffs.size()) != nm) return;
  const cv::Mat P(nm, mh * mw, CV_32F, const_cast<uchar*>(protos.ptr()));
  const cv::Mat c(1, nm, CV_32F, const_cast<float*>(d.coeffs.data()));
  const cv::Mat logits_row = c * P;  // 1 x (mh*mw)
  const cv::Mat logits = logits_row.reshape(1, mh);
  // Upsample the logits to the input (sigmoid > 0.5 <=> logit > 0), then map the image's pixels
  // back through the letterbox and the box.
  const cv::Rect box = boxInImage(d, lb);
  if (box.empty()) return;
  cv::Mat map_x(box.size(), CV_32F), map_y(box.size(), CV_32F);
  const double sx = static_cast<double>(mw) / lb.input_size.width;
  const double sy = static_cast<double>(mh) / lb.input_size.height;
  for (int y = 0; y < box.height; ++y) {
    for (int x = 0; x < box.width; ++x) {
      const cv::Point2d in = lb.toInput({box.x + x + 0.0, box.y + y + 0.0});
      map_x.at<float>(y, x) = static_cast<float>((in.x + 0.5) * sx - 0.5);
      map_y.at<float>(y, x) = static_cast<float>((in.y + 0.5) * sy - 0.5);
    }
  }
  cv::Mat sampled;
  cv::remap(logits, sampled, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::Mat on;
  cv::compare(sampled, 0.0, on, cv::CMP_GT);
  cv::Mat roi = mask_image(box);
  roi |= on;
}

}  // namespace mask
}  // namespace dypho
