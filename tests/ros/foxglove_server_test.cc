// FoxgloveServer against @foxglove/ws-protocol's client (tests/ros/ws_client.cjs):
// the handshake with the protocol's subprotocol, serverInfo and advertise,
// the client's subscribe, and every published message delivered in order
// with its timestamp and payload.
#include "skidimm/io/ros/foxglove_server.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "core/temp_files.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace ros {
namespace {

// Starts the Node client against `port`; its output is read by finish().
struct Client {
  std::FILE* pipe = nullptr;
  Client(std::uint16_t port, int count) {
    const std::string command = "NODE_PATH='" SKIDIMM_NODE_MODULES "' '" SKIDIMM_NODE "' '" SKIDIMM_SOURCE_DIR
                                "/tests/ros/ws_client.cjs' ws://127.0.0.1:" + std::to_string(port) + " " +
                                std::to_string(count) + " 60";
    pipe = popen(command.c_str(), "r");
  }
  YAML::Node finish() {
    std::string out;
    char buffer[4096];
    std::size_t n = 0;
    while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) out.append(buffer, n);
    EXPECT_EQ(pclose(pipe), 0) << out;
    return YAML::Load(out);
  }
};

bool wait_for(const std::function<bool()>& condition, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

TEST(FoxgloveServer, AnIndependentClientSubscribesAndReceivesEveryMessageInOrder) {
  FoxgloveServer server("127.0.0.1", 0, "skidimm test");
  ASSERT_GT(server.port(), 0);
  const std::uint32_t channel =
      server.add_channel("/skidimm/estimate", "json", "skidimm.Estimate", "{\"type\":\"object\"}", "jsonschema");
  Client client(server.port(), 50);
  ASSERT_TRUE(wait_for([&] { return server.subscriptions() == 1; }, 30)) << "the client never subscribed";
  for (int k = 0; k < 50; ++k) {
    server.publish(channel, 1000000000ull * 100 + static_cast<std::uint64_t>(k) * 500000000ull,
                   "{\"k\":" + std::to_string(k) + ",\"p\":\"x\"}");
  }
  const YAML::Node result = client.finish();
  EXPECT_EQ(result["serverInfo"]["name"].as<std::string>(), "skidimm test");
  ASSERT_EQ(result["channels"].size(), 1u);
  EXPECT_EQ(result["channels"][0]["topic"].as<std::string>(), "/skidimm/estimate");
  EXPECT_EQ(result["channels"][0]["schemaEncoding"].as<std::string>(), "jsonschema");
  ASSERT_EQ(result["messages"].size(), 50u);
  for (int k = 0; k < 50; ++k) {
    const YAML::Node m = result["messages"][k];
    EXPECT_EQ(m["topic"].as<std::string>(), "/skidimm/estimate");
    EXPECT_EQ(m["json"]["k"].as<int>(), k);
    EXPECT_EQ(m["timestamp"].as<std::string>(), std::to_string(100000000000ull + k * 500000000ull));
  }
  server.close();
  EXPECT_EQ(server.clients(), 0);
}

TEST(FoxgloveServer, APortInUseIsAClearError) {
  FoxgloveServer first("127.0.0.1", 0, "first");
  try {
    FoxgloveServer second("127.0.0.1", first.port(), "second");
    ADD_FAILURE() << "two servers on one port";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--serve: cannot listen on 127.0.0.1:" + std::to_string(first.port())),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(FoxgloveServer("not an address", 0, "x"), Error);
}

}  // namespace
}  // namespace ros
}  // namespace skidimm
