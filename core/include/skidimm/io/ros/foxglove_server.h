// FoxgloveServer: a WebSocket server speaking the Foxglove WebSocket
// protocol (subprotocol "foxglove.websocket.v1",
// https://github.com/foxglove/ws-protocol), so Foxglove (or any client of
// the protocol) shows skidimm's estimates live: `skidimm run --serve PORT`.
//
// What it implements of the protocol: serverInfo and advertise on connect
// (every channel added), subscribe and unsubscribe from the client, and
// message data (binary opcode 1: subscription id, timestamp, payload) to the
// subscribed clients; a status message answers an operation it does not
// support. Built on Boost.Beast and Boost.Asio (header-only, in the Boost
// skidimm already uses), on one thread of its own.
//
// publish() never blocks the caller (the filter's loop): messages are queued
// per client, and a client that falls more than 1024 messages behind loses
// its oldest ones.
#ifndef SKIDIMM_IO_ROS_FOXGLOVE_SERVER_H_
#define SKIDIMM_IO_ROS_FOXGLOVE_SERVER_H_

#include <cstdint>
#include <memory>
#include <string>

namespace skidimm {
namespace ros {

class FoxgloveServer {
 public:
  // Listens on `host` (e.g. "127.0.0.1", or "0.0.0.0" for every interface)
  // and `port` (0: a free port, see port()). Throws Error naming the address
  // when it cannot listen.
  FoxgloveServer(const std::string& host, std::uint16_t port, const std::string& name);
  // Closes every connection and stops the thread.
  ~FoxgloveServer();
  FoxgloveServer(const FoxgloveServer&) = delete;
  FoxgloveServer& operator=(const FoxgloveServer&) = delete;

  std::uint16_t port() const;

  // Advertises a channel to every client (those connected and those to
  // come); returns its id.
  std::uint32_t add_channel(const std::string& topic, const std::string& encoding, const std::string& schema_name,
                            const std::string& schema, const std::string& schema_encoding);
  // Sends `payload` to every client subscribed to `channel`. Thread-safe.
  void publish(std::uint32_t channel, std::uint64_t timestamp_ns, const std::string& payload);
  // Clients connected now.
  int clients() const;
  // Subscriptions of all clients now (a test waits for one before sending).
  int subscriptions() const;
  // Messages dropped so far for clients that fell behind.
  long dropped() const;
  // Closes every connection gracefully (WebSocket close), waiting at most
  // `seconds` for the messages still queued to be sent.
  void close(double seconds = 2.0);

 private:
  class Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_IO_ROS_FOXGLOVE_SERVER_H_
