// The sequential scan of the face spill that the ring rounds and the chunk output run: frames
// read and tagged ahead, each face handed over with its tag.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "format/record_file.h"
#include "stream/partition/partition_run.h"

namespace gaussmesh::stream::detail {

using format::Code;

template <class Tag, class Fn, class Stop>
Status PartitionRun::scan_faces(int bitmap, std::uint32_t unknown, Tag&& tag_of, Fn&& fn, Stop&& stop, FrameReadAhead::Skip skip,
                                const std::function<void(std::size_t)>& begin) {
  const std::uint64_t nv = out_.vertices;
  auto reader = format::RecordReader::open(faces_path_, kFaceSpillRecordKind, sizeof(Triangle));
  if (!reader) return reader.status();
  if ((*reader)->records() != out_.faces) {
    return Status::error(Code::kBadInput, faces_path_, "holds " + std::to_string((*reader)->records()) + " faces, ingest wrote " +
                                                          std::to_string(out_.faces) + " (temporary file damaged)");
  }
  // tag_of == nullptr: no tags, no windows; fn gets 0.
  constexpr bool kTags = !std::is_same_v<std::decay_t<Tag>, std::nullptr_t>;
  std::optional<FaceWindows> tag_windows;
  if constexpr (kTags) {
    tag_windows.emplace(FaceWindows{FileWindow(cache_->fd(owners_file_), shares_.window), std::nullopt});
    if (bitmap >= 0) tag_windows->bitmap.emplace(cache_->fd(bitmap), shares_.window);
  }
  const std::string bitmap_path = bitmap >= 0 ? cache_->path(bitmap) : std::string();
  // Frames are read, decompressed and tagged one ahead on another thread: the scan's thread is
  // the partition's bottleneck, and the tags take its owner and bitmap lookups for most faces.
  // A window miss is a pread (a few µs); a face costs tens of ns. A frame may miss about once per
  // 256 faces; past that, the rest of the frame goes untagged (the scan's thread looks through the
  // cache, which may still hold the file) and so do the next 1, 2, 4 ... 64 frames, doubling while
  // frames keep missing. Disorder is often local (a stretch of the input that jumps about the
  // ids), so tagging resumes once frames stop missing rather than staying off for the rest of
  // the scan; on ids shuffled throughout, the windows are read for one frame in 64.
  constexpr std::uint64_t kWindowMissFaces = 256, kTagSlice = 1024, kMaxBackOff = 64;
  std::uint64_t untagged = 0, back_off = 0, pass_over = 0;  // the tagger's; read once its thread is joined
  struct CountUntagged {  // destroyed after the read-ahead below
    const std::uint64_t& frames;
    std::uint64_t& count;
    ~CountUntagged() { count += frames; }
  } count_untagged{untagged, out_.untagged_frames};
  FrameReadAhead::Tagger tagger;
  if constexpr (kTags) tagger = [&](const std::vector<Triangle>& faces, std::vector<std::uint32_t>& tags) -> Status {
    FaceWindows& windows = *tag_windows;
    auto misses = [&] { return windows.owners.misses() + (windows.bitmap ? windows.bitmap->misses() : 0); };
    std::size_t tagged = 0;
    if (pass_over > 0) {
      --pass_over;
    } else {
      const std::uint64_t before = misses();
      bool missing = false;
      while (tagged < faces.size() && !missing) {
        const std::size_t end = std::min(faces.size(), tagged + kTagSlice);
        for (; tagged < end; ++tagged) tags[tagged] = tag_of(faces[tagged], windows);
        missing = (misses() - before) * kWindowMissFaces > tagged + kWindowMissFaces;
      }
      back_off = missing ? std::clamp<std::uint64_t>(2 * back_off, 1, kMaxBackOff) : 0;
      pass_over = back_off;
    }
    if (tagged < faces.size()) {
      ++untagged;
      std::fill(tags.begin() + static_cast<std::ptrdiff_t>(tagged), tags.end(), unknown);
    }
    if (!windows.owners.error().empty()) return Status::error(Code::kOutput, owners_path_, "read failed: " + windows.owners.error());
    if (windows.bitmap && !windows.bitmap->error().empty())
      return Status::error(Code::kOutput, bitmap_path, "read failed: " + windows.bitmap->error());
    return {};
  };
  FrameReadAhead ahead(**reader, std::move(tagger), std::move(skip), options_.threads > 1);
  std::vector<Triangle> batch;
  std::vector<std::uint32_t> tags;
  std::uint64_t first = 0;
  for (std::size_t frame = 0;; ++frame) {
    std::uint64_t skipped = 0;
    GM_RETURN_IF_ERROR(ahead.next(batch, tags, skipped));
    if (batch.empty() && skipped == 0) return {};
    if (skipped > 0) {
      first += skipped;
      continue;
    }
    begin(frame);
    for (std::size_t i = 0; i < batch.size(); ++i) {
      const Triangle& t = batch[i];
      if (t.v[0] >= nv || t.v[1] >= nv || t.v[2] >= nv) {
        return Status::error(Code::kBadInput, faces_path_,
                             "face " + std::to_string(first + i) + " refers to a vertex out of range (temporary file damaged)");
      }
      fn(first + i, t, kTags ? tags[i] : 0u);
    }
    first += batch.size();
    if (options_.progress) options_.progress(scan_pass_, first, out_.faces);
    if (stop()) return Status::error(Code::kOutput, out_.dir, "stopped");
    GM_RETURN_IF_ERROR(cache_->status());
  }
}

}  // namespace gaussmesh::stream::detail
