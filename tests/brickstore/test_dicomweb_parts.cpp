// The GL-free, socket-free parts of the DICOMweb input, on buffers: the multipart/related parser (boundaries, quoted
// boundary parameters, pieces split anywhere, truncation at every byte, every malformation), dicomweb:// URLs, QIDO-RS
// answers and credentials. The same code against a real server: tests/dicomweb (Orthanc).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "InputRefusals.h"
#include "brickstore/ingest/dicomweb/DicomWebUrl.h"
#include "brickstore/ingest/dicomweb/HttpClient.h"
#include "brickstore/ingest/dicomweb/Multipart.h"
#include "brickstore/ingest/dicomweb/QidoResults.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using store::MultipartError;
using store::MultipartParser;
using test::expectRefused;

/// What a parser delivered: each part's headers and body.
struct Collected final : store::PartHandler {
  struct Part {
    store::PartHeaders headers;
    std::string body;
    bool ended = false;
  };
  std::vector<Part> parts;
  void partBegin(const store::PartHeaders& h) override { parts.push_back({h, "", false}); }
  void partData(const char* d, size_t n) override {
    EXPECT_GT(n, 0u);
    ASSERT_FALSE(parts.empty());
    parts.back().body.append(d, n);
  }
  void partEnd() override { parts.back().ended = true; }
};

const std::string kBoundary = "b0undary-7d:x";

/// A body of two parts whose data holds CR, LF, dashes and near-delimiters (one character short, another boundary,
/// the boundary without its CRLF), with a preamble and an epilogue.
std::string firstData() { return "\r\n--b0undary-7d:\r\n--" + kBoundary.substr(0, 5) + "x--" + kBoundary + "\r\n"; }

std::string twoParts() {
  return "preamble, ignored\r\n"
         "--" +
         kBoundary +
         "\r\n"
         "Content-Type: application/dicom\r\n"
         "Content-Length: " +
         std::to_string(firstData().size()) +
         "\r\n"
         "\r\n" +
         firstData() + "\r\n--" + kBoundary +
         "  \t\r\n"
         "content-type:application/dicom ; transfer-syntax=1.2.840.10008.1.2.1\r\n"
         "\r\n"
         "second\r\n--" +
         kBoundary + "--\r\nepilogue\r\n--" + kBoundary + "\r\nnot a part";
}

std::vector<Collected::Part> parse(const std::vector<std::string>& pieces, const std::string& boundary = kBoundary) {
  Collected c;
  MultipartParser p(boundary, c);
  for (const std::string& piece : pieces) p.feed(piece.data(), piece.size());
  p.finish();
  EXPECT_TRUE(p.complete());
  return c.parts;
}

void expectTwoParts(const std::vector<Collected::Part>& parts) {
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].body, firstData());
  EXPECT_EQ(store::headerValue(parts[0].headers, "content-type"), "application/dicom");
  EXPECT_EQ(store::headerValue(parts[0].headers, "content-length"), std::to_string(firstData().size()));
  EXPECT_EQ(parts[1].body, "second");
  EXPECT_EQ(store::headerValue(parts[1].headers, "content-type"),
            "application/dicom ; transfer-syntax=1.2.840.10008.1.2.1");
  EXPECT_TRUE(parts[0].ended && parts[1].ended);
}

TEST(Multipart, PartsWithNearDelimitersInTheirData) { expectTwoParts(parse({twoParts()})); }

TEST(Multipart, PiecesSplitAtEveryByteGiveTheSameParts) {
  const std::string body = twoParts();
  for (size_t cut = 0; cut <= body.size(); ++cut) {
    SCOPED_TRACE("split at " + std::to_string(cut));
    expectTwoParts(parse({body.substr(0, cut), body.substr(cut)}));
  }
  std::vector<std::string> bytes;
  for (char c : body) bytes.emplace_back(1, c);
  expectTwoParts(parse(bytes));
}

TEST(Multipart, DelimiterAtTheStartEmptyHeadersAndEmptyBody) {
  const std::string body =
      "--" + kBoundary + "\r\n\r\n\r\n--" + kBoundary + "\r\nA: 1\r\n\r\nx\r\n--" + kBoundary + "--";
  const auto parts = parse({body});
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_TRUE(parts[0].headers.empty());
  EXPECT_EQ(parts[0].body, "");
  EXPECT_EQ(store::headerValue(parts[1].headers, "a"), "1");
  EXPECT_EQ(parts[1].body, "x");
}

TEST(Multipart, EveryTruncationIsReportedAsOne) {
  const std::string body = twoParts();
  const size_t complete = body.find("second\r\n--" + kBoundary + "--") + std::string("second\r\n--").size() +
                          kBoundary.size() + 2;  // just past the closing "--"
  for (size_t n = 0; n < body.size(); ++n) {
    Collected c;
    MultipartParser p(kBoundary, c);
    p.feed(body.data(), n);
    if (n >= complete) {
      EXPECT_NO_THROW(p.finish()) << n;
      continue;
    }
    try {
      p.finish();
      ADD_FAILURE() << "a body cut after " << n << " bytes was accepted";
    } catch (const MultipartError& e) {
      EXPECT_TRUE(e.truncated()) << n << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find("ends"), std::string::npos) << e.what();
    }
  }
}

TEST(Multipart, TruncationMessagesSayWhere) {
  auto cutAfter = [](const std::string& body) {
    Collected c;
    MultipartParser p(kBoundary, c);
    p.feed(body.data(), body.size());
    try {
      p.finish();
    } catch (const MultipartError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(cutAfter("no boundary here").find("without a boundary"), std::string::npos);
  EXPECT_NE(cutAfter("--" + kBoundary + "\r\nContent-Type: app").find("headers of part 1"), std::string::npos);
  EXPECT_NE(cutAfter("--" + kBoundary + "\r\n\r\n12345").find("part 1 after 5 bytes"), std::string::npos)
      << cutAfter("--" + kBoundary + "\r\n\r\n12345");
}

void expectMalformed(const std::string& body, const std::string& words, MultipartParser::Limits limits = {}) {
  SCOPED_TRACE(body);
  Collected c;
  try {
    MultipartParser p(kBoundary, c, limits);
    p.feed(body.data(), body.size());
    p.finish();
    ADD_FAILURE() << "accepted; expected an error with '" << words << "'";
  } catch (const MultipartError& e) {
    EXPECT_FALSE(e.truncated()) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << "missing '" << words << "' in: " << e.what();
  }
}

TEST(Multipart, MalformedBodiesAreRefusedByName) {
  const std::string d = "--" + kBoundary;
  expectMalformed(d + "X\r\n\r\nbody\r\n" + d + "--", "followed by 'X");
  expectMalformed(d + "\r\n\r\nbody\r\n" + d + "junk", "followed by 'junk'");
  expectMalformed(d + "--", "closed before its first part");
  expectMalformed(d + "\r\nno colon here\r\n\r\nx\r\n" + d + "--", "is not 'Name: value'");
  expectMalformed(d + "\r\n: empty name\r\n\r\nx\r\n" + d + "--", "is not 'Name: value'");
  expectMalformed(d + "\r\nA: 1\r\n folded\r\n\r\nx\r\n" + d + "--", "folded header line");
  expectMalformed(d + "\r\nA: 1\nB: 2\r\n\r\nx\r\n" + d + "--", "bare CR or LF");
  expectMalformed(d + "\r\nContent-Length: 3\r\n\r\nxx\r\n" + d + "--", "holds 2 bytes, its Content-Length says 3");
  expectMalformed(d + "\r\nContent-Length: -1\r\n\r\nx\r\n" + d + "--", "is not a byte count");
  expectMalformed(d + "\r\nContent-Length: 1\r\nContent-Length: 1\r\n\r\nx\r\n" + d + "--", "given twice");
  expectMalformed(d + std::string(300, ' ') + "\r\n", "spaces after the delimiter");
  MultipartParser::Limits small;
  small.headerBytes = 64;
  expectMalformed(d + "\r\nX: " + std::string(100, 'y') + "\r\n\r\n", "exceed 64 bytes", small);
  small = {};
  small.preambleBytes = 100;
  expectMalformed(std::string(200, 'p') + "\r\n" + d, "no boundary in its first 100 bytes", small);
  small = {};
  small.parts = 2;
  expectMalformed(d + "\r\n\r\na\r\n" + d + "\r\n\r\nb\r\n" + d + "\r\n\r\nc\r\n" + d + "--", "more than 2 parts",
                  small);
}

TEST(Multipart, AHandlersErrorPassesOut) {
  struct Refusing final : store::PartHandler {
    void partBegin(const store::PartHeaders&) override {}
    void partData(const char*, size_t) override { throw std::runtime_error("disk full"); }
    void partEnd() override {}
  } refusing;
  MultipartParser p(kBoundary, refusing);
  const std::string body = "--" + kBoundary + "\r\n\r\n" + std::string(100, 'x');
  EXPECT_THROW(p.feed(body.data(), body.size()), std::runtime_error);
}

TEST(MultipartType, ParametersQuotedOrNotInAnyOrderAndCase) {
  auto t = store::parseMultipartType("multipart/related; type=\"application/dicom\"; boundary=abc-123");
  EXPECT_EQ(t.boundary, "abc-123");
  EXPECT_EQ(t.type, "application/dicom");
  t = store::parseMultipartType("Multipart/Related;Boundary=\"has space:and=equals?\" ;TYPE=Application/DICOM;");
  EXPECT_EQ(t.boundary, "has space:and=equals?");
  EXPECT_EQ(t.type, "application/dicom");
  t = store::parseMultipartType("multipart/related; boundary=\"esc\\aped\"");
  EXPECT_EQ(t.boundary, "escaped");
  t = store::parseMultipartType("multipart/related; type=application/dicom; boundary=x");  // unquoted, as sent
  EXPECT_EQ(t.type, "application/dicom");
  t = store::parseMultipartType("multipart/related;boundary=x");
  EXPECT_EQ(t.boundary, "x");
  EXPECT_EQ(t.type, "");
  // Orthanc's: 70 characters, quoted type first.
  t = store::parseMultipartType(
      "multipart/related; type=\"application/dicom\"; "
      "boundary=c7d9eaf3-ba44-4a20-ba48-1ec6c67c8329-6821d249-b866-409d-9a33-5807f6d6d");
  EXPECT_EQ(t.boundary.size(), 70u);
}

TEST(MultipartType, RefusalsNameTheProblem) {
  auto refused = [](const std::string& value, const std::string& words) {
    expectRefused([&] { store::parseMultipartType(value); }, {words});
  };
  refused("application/dicom", "is not multipart/related");
  refused("multipart/mixed; boundary=x", "is not multipart/related");
  refused("multipart/related; type=application/dicom", "no boundary parameter");
  refused("multipart/related; boundary=\"\"", "is 0 characters");
  refused("multipart/related; boundary=" + std::string(201, 'a'), "is 201 characters");
  refused("multipart/related; boundary=\"trailing \"", "which a boundary may not");
  refused("multipart/related; boundary=\"at@sign\"", "which a boundary may not");
  refused("multipart/related; boundary=\"open", "not closed");
  refused("multipart/related; boundary=a; boundary=b", "boundary given twice");
  refused("multipart/related; boundary", "expected '='");
  refused("multipart/related boundary=x", "expected ';'");
  refused("multipart", "expected '/'");
}

TEST(DicomWebUrl, SeriesAndStudyUrls) {
  auto u = store::parseDicomWebUrl("dicomweb://pacs.example.org:8042/dicom-web/studies/1.2.3/series/4.5.6");
  EXPECT_EQ(u.base, "http://pacs.example.org:8042/dicom-web");
  EXPECT_EQ(u.study, "1.2.3");
  EXPECT_EQ(u.series, "4.5.6");
  EXPECT_FALSE(u.https);
  EXPECT_EQ(u.instancesUrl(), "http://pacs.example.org:8042/dicom-web/studies/1.2.3/series/4.5.6/instances");
  EXPECT_EQ(u.instanceUrl("4.5.6", "7.8"),
            "http://pacs.example.org:8042/dicom-web/studies/1.2.3/series/4.5.6/instances/7.8");
  u = store::parseDicomWebUrl("DICOMwebS://[::1]/a/b%20c/rs/studies/1.2.3");
  EXPECT_TRUE(u.https);
  EXPECT_EQ(u.base, "https://[::1]/a/b%20c/rs");
  EXPECT_EQ(u.series, "");
  EXPECT_EQ(u.seriesSearchUrl(), "https://[::1]/a/b%20c/rs/studies/1.2.3/series");
  EXPECT_EQ(store::parseDicomWebUrl("dicomweb://h/studies/1/series/2/").base, "http://h");
  EXPECT_TRUE(store::isDicomWebInput("dicomweb://x"));
  EXPECT_FALSE(store::isDicomWebInput("dicom/web"));
}

TEST(DicomWebUrl, RefusalsNameTheProblem) {
  auto refused = [](const std::string& url, const std::string& words) {
    expectRefused([&] { store::parseDicomWebUrl(url); }, {url.substr(0, 20), words});
  };
  refused("dicomweb://h/dicom-web/studies/1.2/series/3.4?limit=1", "a query or fragment");
  refused("dicomweb://h/dicom-web/series/3.4", "no /studies/");
  refused("dicomweb://h/dicom-web/studies/1.2/serie/3.4", "'serie' where 'series' belongs");
  refused("dicomweb://h/dicom-web/studies/1.2/series/3.4/instances", "must end at a study or a series");
  refused("dicomweb://h/dicom-web/studies/1.2/series/..", "is not a DICOM UID");
  refused("dicomweb://h/dicom-web/studies/1..2", "is not a DICOM UID");
  refused("dicomweb://h/dicom-web/studies/" + std::string(65, '1'), "is not a DICOM UID");
  refused("dicomweb://h:0/studies/1", "port '0'");
  refused("dicomweb://h:99999/studies/1", "port '99999'");
  refused("dicomweb://h:/studies/1", "port ''");
  refused("dicomweb://[::1/studies/1", "closing ']'");
  refused("dicomweb://ho st/studies/1", "not a host name");
  refused("dicomweb:///studies/1", "no host");
  refused("dicomweb://h//studies/1", "empty path segment");
  refused("dicomweb://h/a b/studies/1", "percent-encode");
  // Credentials in the URL are refused without repeating them anywhere but the input itself.
  try {
    store::parseDicomWebUrl("dicomweb://alice:hunter2@h/studies/1");
    ADD_FAILURE() << "credentials in the URL accepted";
  } catch (const store::InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("--auth-file"), std::string::npos) << m;
    EXPECT_NE(m.find("VOXBRICK_DICOMWEB_AUTH"), std::string::npos) << m;
  }
}

TEST(DicomWebUrl, Uids) {
  EXPECT_TRUE(store::isDicomUid("1.2.840.10008.5.1.4.1.1.2"));
  EXPECT_TRUE(store::isDicomUid("0"));
  for (const char* bad : {"", ".1", "1.", "1..2", "1.2a", "../x", "1/2", "1 2"})
    EXPECT_FALSE(store::isDicomUid(bad)) << bad;
  EXPECT_FALSE(store::isDicomUid(std::string(65, '1')));
}

std::string qidoInstance(const std::string& sop, const std::string& series = "") {
  std::string j = R"({"00080016":{"vr":"UI","Value":["1.2.840.10008.5.1.4.1.1.2"]},"00080018":{"vr":"UI","Value":[")" +
                  sop + "\"]}";
  if (!series.empty()) j += R"(,"0020000E":{"vr":"UI","Value":[")" + series + "\"]}";
  return j + "}";
}

TEST(Qido, InstancesListedOnceEachWithTheirClass) {
  const auto list = store::parseQidoInstances(
      "[" + qidoInstance("1.2.3", "9.9") + "," + qidoInstance("1.2.4") + "," + qidoInstance("1.2.3", "9.9") + "]",
      "9.9", "GET u");
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].sopInstanceUid, "1.2.3");
  EXPECT_EQ(list[0].sopClassUid, "1.2.840.10008.5.1.4.1.1.2");
  EXPECT_EQ(list[1].sopInstanceUid, "1.2.4");
  EXPECT_TRUE(store::parseQidoInstances("", "9.9", "GET u").empty());  // 204 No Content
  EXPECT_TRUE(store::parseQidoInstances("[]", "9.9", "GET u").empty());
}

TEST(Qido, MalformedAnswersAreRefusedNamingTheRequest) {
  auto refused = [](const std::string& json, const std::string& words) {
    expectRefused([&] { store::parseQidoInstances(json, "9.9", "GET http://h/x"); }, {"GET http://h/x", words});
  };
  refused("{", "is not JSON");
  refused("{}", "not a JSON array");
  refused("[1]", "is not a JSON object");
  refused("[{}]", "has no SOPInstanceUID");
  refused("[" + qidoInstance("../../etc/passwd") + "]", "is not a DICOM UID");
  refused("[" + qidoInstance("1.2") + "," + qidoInstance("1.3", "8.8") + "]", "is of series 8.8, not 9.9");
  refused(R"([{"00080018":"1.2"}])", "not a DICOM JSON attribute object");
  refused(R"([{"00080018":{"vr":"UI","Value":"1.2"}}])", "'Value' is not an array");
  refused(R"([{"00080018":{"vr":"UI","Value":[{"a":1}]}}])", "neither a string nor an integer");
}

/// A page of QIDO-RS results: instances 1.2.FIRST ... 1.2.(FIRST + COUNT - 1).
std::string qidoPage(int first, int count) {
  std::string j = "[";
  for (int i = first; i < first + count; ++i) j += (i > first ? "," : "") + qidoInstance("1.2." + std::to_string(i));
  return j + "]";
}

TEST(Qido, PagesAskForTheResultsAfterThoseReceivedUntilOneBringsFewer) {
  store::QidoInstancePages pages("http://h/s/instances", "9.9", 1 << 20, 4);
  EXPECT_EQ(pages.nextUrl(), "http://h/s/instances?limit=4&offset=0");
  EXPECT_TRUE(pages.add(qidoPage(0, 4), ""));
  EXPECT_EQ(pages.nextUrl(), "http://h/s/instances?limit=4&offset=4");
  // A page cut short by the server's cap (Warning 299): the search goes on after what came.
  EXPECT_TRUE(pages.add(qidoPage(4, 3), "299 example.org \"The number of results exceeded the maximum supported\""));
  EXPECT_EQ(pages.nextUrl(), "http://h/s/instances?limit=4&offset=7");
  // An instance listed again (a series that changed between pages) counts once.
  EXPECT_TRUE(pages.add(qidoPage(6, 4), ""));
  EXPECT_FALSE(pages.add(qidoPage(10, 1), "199 - \"another warning\""));
  ASSERT_EQ(pages.instances().size(), 11u);
  EXPECT_EQ(pages.instances().front().sopInstanceUid, "1.2.0");
  EXPECT_EQ(pages.instances().back().sopInstanceUid, "1.2.10");
  EXPECT_EQ(pages.pages(), 4u);
  // A series of exactly a page: one empty page more ends it; so does a search that matched nothing.
  store::QidoInstancePages exact("http://h/s/instances", "9.9", 1 << 20, 4);
  EXPECT_TRUE(exact.add(qidoPage(0, 4), ""));
  EXPECT_FALSE(exact.add("[]", ""));
  EXPECT_EQ(exact.instances().size(), 4u);
  store::QidoInstancePages none("http://h/s/instances", "9.9", 1 << 20, 4);
  EXPECT_FALSE(none.add("", ""));  // 204 No Content
  EXPECT_TRUE(none.instances().empty());
}

TEST(Qido, AServerThatIgnoresLimitAnsweredEverything) {
  store::QidoInstancePages pages("http://h/s/instances", "9.9", 1 << 20, 4);
  EXPECT_FALSE(pages.add(qidoPage(0, 9), ""));
  EXPECT_EQ(pages.instances().size(), 9u);
}

TEST(Qido, AServerThatIgnoresOffsetIsRefusedNotAskedAgain) {
  store::QidoInstancePages pages("http://h/s/instances", "9.9", 1 << 20, 4);
  EXPECT_TRUE(pages.add(qidoPage(0, 4), ""));
  expectRefused([&] { pages.add(qidoPage(0, 4), ""); }, {"GET http://h/s/instances?limit=4&offset=4", "listed again",
                                                         "ignores QIDO-RS's offset", "more than 4 instances"});
}

TEST(Qido, PagesAreBoundedTogetherAndCheckedEach) {
  const std::string page = qidoPage(0, 4);
  store::QidoInstancePages pages("http://h/s/instances", "9.9", page.size() + 10, 4);
  EXPECT_TRUE(pages.add(page, ""));
  EXPECT_EQ(pages.bytesLeft(), 10u);
  expectRefused([&] { pages.add(qidoPage(4, 4), ""); }, {"offset=4", "answers exceed", "2 pages of 4"});
  store::QidoInstancePages other("http://h/s/instances", "9.9", 1 << 20, 4);
  expectRefused([&] { other.add("[" + qidoInstance("1.3", "8.8") + "]", ""); },
                {"GET http://h/s/instances?limit=4&offset=0", "is of series 8.8, not 9.9"});
}

TEST(Qido, SeriesOfAStudy) {
  const auto series = store::parseQidoSeries(
      R"([{"0020000E":{"vr":"UI","Value":["1.1"]},"00080060":{"vr":"CS","Value":["CT"]},
           "0008103E":{"vr":"LO","Value":["chest"]},"00201209":{"vr":"IS","Value":[12]}},
          {"0020000E":{"vr":"UI","Value":["1.2"]},"00080060":{"vr":"CS","Value":["RTPLAN"]}}])",
      "GET u");
  ASSERT_EQ(series.size(), 2u);
  EXPECT_EQ(series[0].modality, "CT");
  EXPECT_EQ(series[0].description, "chest");
  EXPECT_EQ(series[0].instances, 12);
  EXPECT_EQ(series[1].instances, -1);
  EXPECT_EQ(series[0].studyUid, "");
  // A search of every series (a PACS listed as datasets) reads the study and the patient too; a person name is
  // DICOM JSON's {"Alphabetic": ...}.
  const auto listed = store::parseQidoSeries(
      R"([{"0020000E":{"vr":"UI","Value":["1.1"]},"0020000D":{"vr":"UI","Value":["2.5"]},
           "00081030":{"vr":"LO","Value":["head"]},"00080020":{"vr":"DA","Value":["20261204"]},
           "00100010":{"vr":"PN","Value":[{"Alphabetic":"Doe^Jane"}]},"00100020":{"vr":"LO","Value":["P-77"]},
           "00100030":{"vr":"DA","Value":["19700101"]}},
          {"0020000E":{"vr":"UI","Value":["1.2"]},"00100010":{"vr":"PN"}}])",
      "GET u");
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].studyUid, "2.5");
  EXPECT_EQ(listed[0].studyDescription, "head");
  EXPECT_EQ(listed[0].studyDate, "20261204");
  EXPECT_EQ(listed[0].patientName, "Doe^Jane");
  EXPECT_EQ(listed[0].patientId, "P-77");
  EXPECT_EQ(listed[0].patientBirthDate, "19700101");
  EXPECT_EQ(listed[1].patientName, "");
  expectRefused([] { store::parseQidoSeries(R"([{"0020000E":{"vr":"UI","Value":["1.1"]},"0020000D":{"vr":"UI",
                                              "Value":["x/y"]}}])", "GET u"); },
                {"StudyInstanceUID 'x/y', which is not a DICOM UID"});
  EXPECT_TRUE(store::qidoResultsCut("299 orthanc \"The number of results exceeded the maximum\""));
  EXPECT_FALSE(store::qidoResultsCut("199 misc"));
  EXPECT_FALSE(store::isNonImageModality("CT"));
  EXPECT_FALSE(store::isNonImageModality("RTDOSE"));  // a dose grid is a volume
  EXPECT_TRUE(store::isNonImageModality("RTPLAN"));
  EXPECT_TRUE(store::isNonImageModality("SR"));
  expectRefused([] { store::parseQidoSeries(R"([{"00080060":{"vr":"CS","Value":["CT"]}}])", "GET u"); },
                {"has no SeriesInstanceUID"});
  expectRefused(
      [] {
        store::parseQidoSeries(R"([{"0020000E":{"vr":"UI","Value":["1.1"]},"00201209":{"vr":"IS","Value":["x"]}}])",
                               "GET u");
      },
      {"is not a count"});
}

TEST(DicomWebCredentials, FromAFileOrTheEnvironmentNeverEchoed) {
  test::ScratchDir dir;
  ::unsetenv(store::kDicomWebAuthVariable);
  EXPECT_EQ(store::readHttpCredentials("").scheme, store::HttpCredentials::Scheme::None);
  test::writeFile(dir / "basic", std::string("\n  Basic alice:pa:ss word \n"));
  auto c = store::readHttpCredentials((dir / "basic").string());
  EXPECT_EQ(c.scheme, store::HttpCredentials::Scheme::Basic);
  EXPECT_EQ(c.user, "alice");
  EXPECT_EQ(c.secret, "pa:ss word");
  EXPECT_NE(c.origin.find("--auth-file"), std::string::npos);
  ::setenv(store::kDicomWebAuthVariable, "bearer tok.en-1", 1);
  c = store::readHttpCredentials("");
  EXPECT_EQ(c.scheme, store::HttpCredentials::Scheme::Bearer);
  EXPECT_EQ(c.secret, "tok.en-1");
  EXPECT_EQ(c.origin, store::kDicomWebAuthVariable);
  for (const char* bad : {"hunter2", "basic hunter2", "bearer two words", "digest a:b"}) {
    test::writeFile(dir / "bad", std::string(bad));
    try {
      store::readHttpCredentials((dir / "bad").string());
      ADD_FAILURE() << "accepted";
    } catch (const store::InputError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("expected 'basic USER:PASSWORD' or 'bearer TOKEN'"), std::string::npos) << m;
      EXPECT_EQ(m.find("hunter2"), std::string::npos) << "the secret is in the message: " << m;
      EXPECT_EQ(m.find("words"), std::string::npos) << m;
    }
  }
  ::unsetenv(store::kDicomWebAuthVariable);
  expectRefused([&] { store::readHttpCredentials((dir / "missing").string()); }, {"missing", "cannot read"});
}

}  // namespace
}  // namespace voxbrick
