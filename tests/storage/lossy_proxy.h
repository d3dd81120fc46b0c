// LossyProxy: a TCP relay on a loopback port in front of a real PostgreSQL server that can
// lose one COMMIT's answer on purpose, for the store's unknown-outcome tests. Armed, the
// first client message carrying "COMMIT" is either forwarded and the connection then cut
// before the answer can come back (the transaction commits; the client cannot know), or
// cut before it is forwarded (it never commits). While down, new connections are closed at
// once (a database that cannot be reached); while stalled, nothing is relayed either way
// and no connection is closed (a server that stopped answering: SIGSTOP, a partition).
//
//   LossyProxy proxy(server.port());
//   proxy.Arm(LossyProxy::kAnswerLost);
//   store->AppendJournal(...);   // resolved by reading back
//
// Thread safety: the methods may be called from any thread.
#ifndef TESTS_STORAGE_LOSSY_PROXY_H_
#define TESTS_STORAGE_LOSSY_PROXY_H_

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <string_view>
#include <thread>
#include <vector>

namespace skimap::testing {

class LossyProxy {
 public:
  enum Loss { kNone, kAnswerLost, kCommitLost };

  explicit LossyProxy(int target_port) : target_port_(target_port) {
    listen_fd_ = socket(AF_INET, SOCK_STREAM, 0);
    int one = 1;
    setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in addr = Loopback(0);
    bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    listen(listen_fd_, 64);
    socklen_t len = sizeof addr;
    getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    accept_ = std::thread([this] { AcceptLoop(); });
  }
  ~LossyProxy() {
    stop_ = true;
    shutdown(listen_fd_, SHUT_RDWR);
    close(listen_fd_);
    accept_.join();
    std::lock_guard<std::mutex> lock(mu_);
    for (std::thread& t : relays_) t.join();
  }

  int port() const { return port_; }
  // The next COMMIT (only one) meets `loss`.
  void Arm(Loss loss) { armed_ = loss; }
  // true: new connections are closed at once.
  void SetDown(bool down) { down_ = down; }
  // true: nothing is relayed (connections stay open).
  void SetStalled(bool stalled) { stalled_ = stalled; }
  // COMMITs lost so far.
  int losses() const { return losses_; }

 private:
  static sockaddr_in Loopback(int port) {
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = htons(port);
    return addr;
  }
  void AcceptLoop() {
    while (!stop_) {
      const int client = accept(listen_fd_, nullptr, nullptr);
      if (client < 0) continue;
      if (down_) {
        close(client);
        continue;
      }
      const int server = socket(AF_INET, SOCK_STREAM, 0);
      sockaddr_in addr = Loopback(target_port_);
      if (connect(server, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        close(client);
        close(server);
        continue;
      }
      std::lock_guard<std::mutex> lock(mu_);
      relays_.emplace_back([this, client, server] { Relay(client, server); });
    }
  }
  void Relay(int client, int server) {
    char buf[1 << 16];
    pollfd fds[2] = {{client, POLLIN, 0}, {server, POLLIN, 0}};
    while (!stop_) {
      if (stalled_) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
      if (poll(fds, 2, 200) <= 0) continue;
      if (fds[0].revents != 0) {
        const ssize_t n = read(client, buf, sizeof buf);
        if (n <= 0) break;
        const Loss loss = std::string_view(buf, n).find("COMMIT") != std::string_view::npos
                              ? armed_.exchange(kNone)
                              : kNone;
        if (loss == kCommitLost) {
          ++losses_;
          break;  // never reaches the server
        }
        if (write(server, buf, n) != n) break;
        if (loss == kAnswerLost) {
          ++losses_;
          // The server commits; its answer dies with the connection.
          std::this_thread::sleep_for(std::chrono::milliseconds(300));
          break;
        }
      }
      if (fds[1].revents != 0) {
        const ssize_t n = read(server, buf, sizeof buf);
        if (n <= 0 || write(client, buf, n) != n) break;
      }
    }
    close(client);
    close(server);
  }

  const int target_port_;
  int listen_fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false}, down_{false}, stalled_{false};
  std::atomic<Loss> armed_{kNone};
  std::atomic<int> losses_{0};
  std::thread accept_;
  std::mutex mu_;
  std::vector<std::thread> relays_;
};

}  // namespace skimap::testing

#endif  // TESTS_STORAGE_LOSSY_PROXY_H_
