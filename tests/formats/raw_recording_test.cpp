// The raw recording format (formats/raw_recording.hpp, docs/formats.md "Raw recordings"): what the
// writer's pieces put on disk, byte for byte, and what the reader makes of whole, interrupted and
// foreign files; the listing of a state directory.
#include "formats/raw_recording.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "test_support.hpp"

namespace guideway::formats {
namespace {

using test::TempDir;

void write(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

Sample sample(std::int64_t t, std::uint64_t seq, std::vector<double> values, std::uint32_t flags = 0) {
  Sample s;
  s.t_mono_ns = t;
  s.seq = seq;
  s.flags = flags;
  for (std::size_t i = 0; i < values.size(); ++i) s.value[i] = values[i];
  s.value_count = static_cast<std::uint32_t>(values.size());
  return s;
}

RawRecordingHeader header() {
  RawRecordingHeader h;
  h.device = "bar";
  h.driver = "dbb-can";
  h.started_utc = "2026-11-21T06:31:02.114Z";
  h.started_mono_ns = 2201337459911;
  h.metadata = {{"kind", "dbb"}, {"options", "{\"radius_mm\":100}"}, {"session", "dbb-bar-1"}, {"note", "two\nlines"}};
  h.channels = {{"dL", "m"}, {"angle", "rad"}};
  return h;
}

std::string whole_recording() {
  std::string text = format_raw_header(header());
  append_raw_row(text, sample(2201338004120, 1088, {1.5e-6, 0.25}), 2);
  append_raw_row(text, sample(2201338504377, 1089, {-2e-6}, 4), 2);  // the second channel missing
  append_raw_row(text, sample(2201339004377, 1090, {std::numeric_limits<double>::quiet_NaN(), 0.5}), 2);
  text += format_raw_trailer({.complete = true,
                              .ended_utc = "2026-11-21T06:31:02.361Z",
                              .samples = 3,
                              .samples_lost = 0,
                              .metadata = {{"identification_error", "none\r\nreally"}}});
  return text;
}

TEST(RawRecording, TheWriterPutsTheDocumentedBytesOnDisk) {
  EXPECT_EQ(whole_recording(),
            "# format = guideway/raw/1\n"
            "# device = bar\n"
            "# driver = dbb-can\n"
            "# started_utc = 2026-11-21T06:31:02.114Z\n"
            "# started_mono_ns = 2201337459911\n"
            "# kind = dbb\n"
            "# note = two lines\n"
            "# options = {\"radius_mm\":100}\n"
            "# session = dbb-bar-1\n"
            "t_mono_ns,seq,flags,dL_m,angle_rad\n"
            "2201338004120,1088,0,1.5e-06,0.25\n"
            "2201338504377,1089,4,-2e-06,\n"
            "2201339004377,1090,0,nan,0.5\n"
            "# end = complete\n"
            "# ended_utc = 2026-11-21T06:31:02.361Z\n"
            "# samples = 3\n"
            "# samples_lost = 0\n"
            "# identification_error = none  really\n");
  EXPECT_EQ(raw_recording_path("/var/lib/guideway", "dbb-bar-1"), "/var/lib/guideway/dbb-bar-1.csv");
  EXPECT_EQ(raw_recording_part_path("/var/lib/guideway", "dbb-bar-1"), "/var/lib/guideway/dbb-bar-1.csv.part");
}

TEST(RawRecording, TheReaderGivesBackWhatTheWriterWrote) {
  TempDir dir;
  const std::string path = dir.file("r.csv");
  write(path, whole_recording());
  const RawRecording r = read_raw_recording(path);
  EXPECT_EQ(r.path, path);
  EXPECT_EQ(r.device, "bar");
  EXPECT_EQ(r.driver, "dbb-can");
  ASSERT_EQ(r.channels.size(), 2u);
  EXPECT_EQ(r.channels[0].name, "dL");
  EXPECT_EQ(r.channels[0].unit, "m");
  EXPECT_EQ(r.channels[1].name, "angle");
  EXPECT_EQ(r.channels[1].unit, "rad");
  ASSERT_EQ(r.samples.size(), 3u);
  EXPECT_EQ(r.samples[0].t_mono_ns, 2201338004120);
  EXPECT_EQ(r.samples[0].seq, 1088u);
  EXPECT_EQ(r.samples[0].value_count, 2u);
  EXPECT_EQ(r.samples[0].value[0], 1.5e-6);
  EXPECT_EQ(r.samples[0].value[1], 0.25);
  EXPECT_EQ(r.samples[1].flags, 4u);
  EXPECT_EQ(r.samples[1].value_count, 1u);
  EXPECT_EQ(r.samples[1].value[0], -2e-6);
  EXPECT_TRUE(std::isnan(r.samples[2].value[0]));
  EXPECT_TRUE(r.complete);
  EXPECT_EQ(r.end_marker, "complete");
  EXPECT_EQ(r.samples_lost, 0u);
  EXPECT_EQ(r.dropped_partial_line, 0u);
  EXPECT_EQ(r.required("kind"), "dbb");
  EXPECT_EQ(r.required("session"), "dbb-bar-1");
  EXPECT_EQ(r.metadata.at("options"), "{\"radius_mm\":100}");
  EXPECT_EQ(r.metadata.at("identification_error"), "none  really");
  EXPECT_EQ(r.metadata.at("samples"), "3");
}

TEST(RawRecording, AnInterruptedRecordingIsReadAndSaidIncomplete) {
  TempDir dir;
  std::string text = format_raw_header(header());
  append_raw_row(text, sample(10, 1, {1.0, 2.0}), 2);
  append_raw_row(text, sample(20, 2, {3.0, 4.0}), 2);
  text += "30,3,0,5.";  // a kill in the middle of a write()
  const std::string part = dir.file("r.csv.part");
  write(part, text);
  const RawRecording r = read_raw_recording(part);
  EXPECT_FALSE(r.complete);
  EXPECT_EQ(r.end_marker, "");
  EXPECT_EQ(r.dropped_partial_line, 1u);
  ASSERT_EQ(r.samples.size(), 2u);
  EXPECT_EQ(r.samples[1].seq, 2u);

  // A whole file renamed back to .part, one marked aborted, and one that lost samples are not whole either.
  write(part, whole_recording());
  EXPECT_FALSE(read_raw_recording(part).complete);
  const std::string aborted = dir.file("a.csv");
  std::string a = whole_recording();
  a.replace(a.find("# end = complete"), 16, "# end = aborted");
  write(aborted, a);
  EXPECT_FALSE(read_raw_recording(aborted).complete);
  EXPECT_EQ(read_raw_recording(aborted).end_marker, "aborted");
  const std::string lost = dir.file("l.csv");
  std::string l = whole_recording();
  l.replace(l.find("# samples_lost = 0"), 18, "# samples_lost = 7");
  write(lost, l);
  EXPECT_FALSE(read_raw_recording(lost).complete);
  EXPECT_EQ(read_raw_recording(lost).samples_lost, 7u);
}

TEST(RawRecording, OtherFilesAreRefusedNamingTheFile) {
  TempDir dir;
  const std::string profile = dir.file("p.csv");
  write(profile, "# format = guideway/profile/1\nx_mm,z_um\n0,1\n");
  try {
    (void)read_raw_recording(profile);
    FAIL() << "a profile read as a raw recording";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), profile + ": format \"guideway/profile/1\" is not a raw recording (guideway/raw/1)");
  }
  const std::string no_device = dir.file("n.csv");
  std::string text = whole_recording();
  text.erase(text.find("# device = bar\n"), 15);
  write(no_device, text);
  EXPECT_THROW((void)read_raw_recording(no_device), std::runtime_error);
  write(no_device, whole_recording());
  try {
    (void)read_raw_recording(no_device).required("wanted");
    FAIL() << "an absent header key was given";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), no_device + ": not a complete raw recording header (no \"wanted\")");
  }
  const std::string bad_column = dir.file("b.csv");
  write(bad_column, "# format = guideway/raw/1\n# device = d\n# driver = x\nt_mono_ns,seq,flags,nounit\n1,1,0,2\n");
  EXPECT_THROW((void)read_raw_recording(bad_column), std::runtime_error);
}

TEST(RawRecording, TheListingHoldsRawRecordingsOnlySortedWithTheirState) {
  TempDir dir;
  write(dir.file("b.csv.part"), format_raw_header(header()));
  write(dir.file("a.csv"), whole_recording());
  write(dir.file("a.dbb-run.csv"), "# format = guideway/dbb-run/1\nangle_deg,dL_um\n");  // a derived file
  write(dir.file("c.txt"), whole_recording());
  const auto list = list_raw_recordings(dir.path().string());
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].path, dir.file("a.csv"));
  EXPECT_TRUE(list[0].complete);
  EXPECT_EQ(list[0].bytes, whole_recording().size());
  EXPECT_EQ(list[1].path, dir.file("b.csv.part"));
  EXPECT_FALSE(list[1].complete);
  EXPECT_TRUE(is_raw_recording(dir.file("a.csv")));
  EXPECT_FALSE(is_raw_recording(dir.file("a.dbb-run.csv")));
  EXPECT_TRUE(list_raw_recordings(dir.file("missing")).empty());
}

}  // namespace
}  // namespace guideway::formats
