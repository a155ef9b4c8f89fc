#include "skidimm/io/ros/foxglove_server.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <future>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "skidimm/errors.h"
#include "skidimm/io/ros/estimate_json.h"

namespace skidimm {
namespace ros {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

// An advertised channel. Not in the anonymous namespace below: the server's
// Impl, which has external linkage, holds them, and a member of internal
// linkage in it is what gcc's -Wsubobject-linkage warns about in a unity build.
namespace internal {

struct FoxgloveChannel {
  std::uint32_t id;
  std::string topic, encoding, schema_name, schema, schema_encoding;
};

}  // namespace internal

namespace {

constexpr const char* kSubprotocol = "foxglove.websocket.v1";
constexpr std::size_t kMaxQueued = 1024;
constexpr std::uint8_t kMessageData = 0x01;

using Channel = internal::FoxgloveChannel;

std::string advertise(const std::vector<Channel>& channels) {
  std::string out = "{\"op\":\"advertise\",\"channels\":[";
  for (std::size_t i = 0; i < channels.size(); ++i) {
    const Channel& c = channels[i];
    out += (i == 0 ? "" : ",") + std::string("{\"id\":") + std::to_string(c.id) + ",\"topic\":" + json_string(c.topic) +
           ",\"encoding\":" + json_string(c.encoding) + ",\"schemaName\":" + json_string(c.schema_name) +
           ",\"schema\":" + json_string(c.schema) + ",\"schemaEncoding\":" + json_string(c.schema_encoding) + "}";
  }
  return out + "]}";
}

std::string status(int level, const std::string& message) {
  return "{\"op\":\"status\",\"level\":" + std::to_string(level) + ",\"message\":" + json_string(message) + "}";
}

}  // namespace

class FoxgloveServer::Impl : public std::enable_shared_from_this<FoxgloveServer::Impl> {
 public:
  class Session;

  Impl(const std::string& host, std::uint16_t port, std::string name)
      : name_(std::move(name)), work_(io_.get_executor()), acceptor_(io_) {
    beast::error_code ec;
    const auto address = asio::ip::make_address(host, ec);
    if (ec) throw Error("--serve: '" + host + "' is not an IP address (" + ec.message() + ")");
    const tcp::endpoint endpoint(address, port);
    acceptor_.open(endpoint.protocol(), ec);
    if (!ec) acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor_.bind(endpoint, ec);
    if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) {
      throw Error("--serve: cannot listen on " + host + ":" + std::to_string(port) + ": " + ec.message());
    }
    port_ = acceptor_.local_endpoint().port();
  }

  void start() {
    accept();
    auto ran = std::make_shared<std::promise<void>>();
    finished_ = ran->get_future();
    thread_ = std::thread([self = shared_from_this(), ran] {
      self->io_.run();
      ran->set_value();
    });
  }

  void stop(double seconds);

  void accept();
  void publish(std::uint32_t channel, std::uint64_t timestamp, std::shared_ptr<const std::string> payload);

  std::string name_;
  asio::io_context io_;
  // Keeps run() going until stop() has queued its last handler: a handler
  // posted after run() returned would never run, and its hold on this
  // object would keep the object alive forever.
  asio::executor_work_guard<asio::io_context::executor_type> work_;
  tcp::acceptor acceptor_;
  std::thread thread_;
  std::future<void> finished_;  // ready when the thread's run() has returned
  std::uint16_t port_ = 0;
  std::mutex mutex_;  // channels_ (read on the io thread, added from the caller's)
  std::vector<Channel> channels_;
  std::vector<std::weak_ptr<Session>> sessions_;  // the io thread's
  std::atomic<int> clients_{0};
  std::atomic<int> subscriptions_{0};
  std::atomic<long> dropped_{0};
  std::atomic<bool> stopping_{false};
  std::uint64_t session_count_ = 0;
};

class FoxgloveServer::Impl::Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket socket, std::shared_ptr<Impl> server) : ws_(std::move(socket)), server_(std::move(server)) {}
  ~Session() {
    if (open_) --server_->clients_;
    server_->subscriptions_ -= static_cast<int>(subscriptions_.size());
  }

  void run() {
    http::async_read(ws_.next_layer(), buffer_, request_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_request(ec); });
  }

  void on_request(beast::error_code ec) {
    if (ec) return;
    if (!websocket::is_upgrade(request_)) {
      // A browser or curl: say what this is, then close.
      auto response = std::make_shared<http::response<http::string_body>>(http::status::upgrade_required,
                                                                        request_.version());
      response->set(http::field::content_type, "text/plain");
      response->body() = "skidimm: a Foxglove WebSocket server (" + std::string(kSubprotocol) +
                         "); open it in Foxglove with 'Open connection' > 'Foxglove WebSocket'\n";
      response->prepare_payload();
      http::async_write(ws_.next_layer(), *response,
                        [self = shared_from_this(), response](beast::error_code, std::size_t) {
                          beast::error_code ignored;
                          self->ws_.next_layer().socket().shutdown(tcp::socket::shutdown_both, ignored);
                        });
      return;
    }
    const std::string offered(request_[http::field::sec_websocket_protocol]);
    ws_.set_option(websocket::stream_base::decorator([offered](websocket::response_type& response) {
      response.set(http::field::server, "skidimm");
      // Foxglove offers the subprotocol and requires it back.
      if (offered.find(kSubprotocol) != std::string::npos) {
        response.set(http::field::sec_websocket_protocol, kSubprotocol);
      }
    }));
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.async_accept(request_, [self = shared_from_this()](beast::error_code e) { self->on_accept(e); });
  }

  void on_accept(beast::error_code ec) {
    if (ec) return;
    open_ = true;
    ++server_->clients_;
    send_text("{\"op\":\"serverInfo\",\"name\":" + json_string(server_->name_) +
              ",\"capabilities\":[],\"supportedEncodings\":[],\"metadata\":{},\"sessionId\":\"" +
              std::to_string(reinterpret_cast<std::uintptr_t>(this)) + "\"}");
    std::vector<Channel> channels;
    {
      std::lock_guard<std::mutex> lock(server_->mutex_);
      channels = server_->channels_;
    }
    if (!channels.empty()) send_text(advertise(channels));
    read();
  }

  void read() {
    ws_.async_read(incoming_, [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_read(ec); });
  }

  void on_read(beast::error_code ec) {
    if (ec) return;  // closed: the session ends when its last handler does
    if (ws_.got_text()) handle(beast::buffers_to_string(incoming_.data()));
    incoming_.consume(incoming_.size());
    read();
  }

  // A client operation (JSON): subscribe and unsubscribe are served.
  void handle(const std::string& text) {
    try {
      const YAML::Node op = YAML::Load(text);
      const std::string name = op["op"] ? op["op"].as<std::string>() : "";
      if (name == "subscribe") {
        for (const YAML::Node& s : op["subscriptions"]) {
          const auto id = s["id"].as<std::uint32_t>();
          if (subscriptions_.emplace(id, s["channelId"].as<std::uint32_t>()).second) ++server_->subscriptions_;
        }
      } else if (name == "unsubscribe") {
        for (const YAML::Node& id : op["subscriptionIds"]) {
          if (subscriptions_.erase(id.as<std::uint32_t>()) > 0) --server_->subscriptions_;
        }
      } else {
        send_text(status(1, "skidimm does not support the operation '" + name + "'"));
      }
    } catch (const YAML::Exception& e) {
      send_text(status(2, std::string("cannot read the operation: ") + e.what()));
    }
  }

  void deliver(std::uint32_t channel, std::uint64_t timestamp, const std::string& payload) {
    for (const auto& [subscription, subscribed] : subscriptions_) {
      if (subscribed != channel) continue;
      auto frame = std::make_shared<std::string>(1 + 4 + 8 + payload.size(), '\0');
      (*frame)[0] = static_cast<char>(kMessageData);
      std::memcpy(&(*frame)[1], &subscription, 4);
      std::memcpy(&(*frame)[5], &timestamp, 8);
      std::memcpy(&(*frame)[13], payload.data(), payload.size());
      enqueue(std::move(frame), true);
    }
  }

  void send_text(std::string text) { enqueue(std::make_shared<std::string>(std::move(text)), false); }

  void enqueue(std::shared_ptr<const std::string> frame, bool binary) {
    if (!open_ || closing_) return;
    // A client that cannot keep up loses its oldest messages, not the filter its pace.
    if (queue_.size() >= kMaxQueued) {
      for (auto it = queue_.begin() + (writing_ ? 1 : 0); it != queue_.end(); ++it) {
        if (it->second) {
          queue_.erase(it);
          ++server_->dropped_;
          break;
        }
      }
    }
    queue_.emplace_back(std::move(frame), binary);
    if (!writing_) write();
  }

  void write() {
    writing_ = true;
    ws_.binary(queue_.front().second);
    ws_.async_write(asio::buffer(*queue_.front().first),
                    [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_write(ec); });
  }

  void on_write(beast::error_code ec) {
    queue_.pop_front();
    writing_ = false;
    if (ec) {
      queue_.clear();
      return;
    }
    if (!queue_.empty()) {
      write();
    } else if (closing_) {
      close_now();
    }
  }

  bool idle() const { return queue_.empty() && !writing_; }

  void close() {
    if (!open_) return;
    closing_ = true;
    if (!writing_) close_now();
  }

  void close_now() {
    ws_.async_close(websocket::close_code::normal, [self = shared_from_this()](beast::error_code) {});
  }

  // Ends the connection at once: every pending operation completes with an error.
  void shut() {
    beast::error_code ignored;
    ws_.next_layer().socket().shutdown(tcp::socket::shutdown_both, ignored);
    ws_.next_layer().socket().close(ignored);
  }

 private:
  websocket::stream<beast::tcp_stream> ws_;
  std::shared_ptr<Impl> server_;
  beast::flat_buffer buffer_;
  beast::flat_buffer incoming_;
  http::request<http::string_body> request_;
  std::deque<std::pair<std::shared_ptr<const std::string>, bool>> queue_;
  std::map<std::uint32_t, std::uint32_t> subscriptions_;  // subscription id -> channel
  bool writing_ = false;
  bool open_ = false;
  bool closing_ = false;
};

void FoxgloveServer::Impl::accept() {
  acceptor_.async_accept(io_, [self = shared_from_this()](beast::error_code ec, tcp::socket socket) {
    if (ec || self->stopping_) return;
    auto& sessions = self->sessions_;
    sessions.erase(std::remove_if(sessions.begin(), sessions.end(), [](const auto& w) { return w.expired(); }),
                   sessions.end());
    auto session = std::make_shared<Session>(std::move(socket), self);
    sessions.push_back(session);
    session->run();
    self->accept();
  });
}

void FoxgloveServer::Impl::publish(std::uint32_t channel, std::uint64_t timestamp,
                                   std::shared_ptr<const std::string> payload) {
  asio::post(io_, [self = shared_from_this(), channel, timestamp, payload] {
    for (const auto& weak : self->sessions_) {
      if (auto session = weak.lock()) session->deliver(channel, timestamp, *payload);
    }
  });
}

void FoxgloveServer::Impl::stop(double seconds) {
  if (stopping_.exchange(true)) return;
  // Let the clients receive what is queued, then close them.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < deadline) {
    auto idle = std::make_shared<std::promise<bool>>();
    auto done = idle->get_future();
    asio::post(io_, [self = shared_from_this(), idle] {
      bool all = true;
      for (const auto& weak : self->sessions_) {
        if (auto s = weak.lock()) all = all && s->idle();
      }
      idle->set_value(all);
    });
    if (done.wait_until(deadline) != std::future_status::ready || done.get()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  asio::post(io_, [self = shared_from_this()] {
    beast::error_code ignored;
    self->acceptor_.close(ignored);
    for (const auto& weak : self->sessions_) {
      if (auto s = weak.lock()) s->close();
    }
  });
  // The close handshakes, briefly; then every socket is shut, which ends
  // every pending operation, and the thread's run() returns once they have.
  const auto close_deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
  while (clients_ > 0 && std::chrono::steady_clock::now() < close_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  asio::post(io_, [self = shared_from_this()] {
    for (const auto& weak : self->sessions_) {
      if (auto s = weak.lock()) s->shut();
    }
    self->sessions_.clear();
  });
  work_.reset();
  if (finished_.wait_for(std::chrono::seconds(2)) != std::future_status::ready) io_.stop();
  if (thread_.joinable()) thread_.join();
}

FoxgloveServer::FoxgloveServer(const std::string& host, std::uint16_t port, const std::string& name)
    : impl_(std::make_shared<Impl>(host, port, name)) {
  impl_->start();
}

FoxgloveServer::~FoxgloveServer() { close(0.5); }

std::uint16_t FoxgloveServer::port() const { return impl_->port_; }
int FoxgloveServer::clients() const { return impl_->clients_; }
int FoxgloveServer::subscriptions() const { return impl_->subscriptions_; }
long FoxgloveServer::dropped() const { return impl_->dropped_; }

std::uint32_t FoxgloveServer::add_channel(const std::string& topic, const std::string& encoding,
                                          const std::string& schema_name, const std::string& schema,
                                          const std::string& schema_encoding) {
  Channel channel;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex_);
    channel = Channel{static_cast<std::uint32_t>(impl_->channels_.size() + 1), topic, encoding, schema_name, schema,
                      schema_encoding};
    impl_->channels_.push_back(channel);
  }
  asio::post(impl_->io_, [impl = impl_, channel] {
    for (const auto& weak : impl->sessions_) {
      if (auto s = weak.lock()) s->send_text(advertise({channel}));
    }
  });
  return channel.id;
}

void FoxgloveServer::publish(std::uint32_t channel, std::uint64_t timestamp_ns, const std::string& payload) {
  impl_->publish(channel, timestamp_ns, std::make_shared<const std::string>(payload));
}

void FoxgloveServer::close(double seconds) {
  if (impl_) impl_->stop(seconds);
}

}  // namespace ros
}  // namespace skidimm
